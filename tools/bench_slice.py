#!/usr/bin/python3
"""Slice benchmark (`--slice`, docs/rendering.md and docs/streaming.md "Slices"): what a slice
saves and what it costs in accuracy, on the porous scene.

1. In memory (`mdstream bench --slice`): each slice from the three default views, the culled
   image against its every-particle reference (pixels beyond the 0.1 tolerance), the share of
   meshlets culled, and the GPU frame after convergence against drawing every meshlet.
2. Streaming (`mdstream stress --slice`): the orbit, fly-through and jump paths with a pool of
   1/8 of the store, the whole store against each slice: hit rate against the offline Belady
   replay, bytes read, nodes never read because the slice removes them.

Writes docs/results/slice.md and slice.csv.

  /usr/bin/python3 tools/bench_slice.py [--quick] [--mdstream build/mdstream]
"""
import argparse
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (fmt_bytes, machine_info, make_store, newest_mdstream, open_work, sh,  # noqa: E402
                          write_csv, write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def slices_for(bounds_min, bounds_max):
    """A slab across x (a tenth of the width, at the centre) and a diagonal cut keeping the part
    with x + y below 3/4 of the way, as --slice specs."""
    cx = 0.5 * (bounds_min[0] + bounds_max[0])
    wx = bounds_max[0] - bounds_min[0]
    d = 0.75 * (bounds_max[0] + bounds_max[1]) / 2 ** 0.5 + 0.25 * (bounds_min[0] + bounds_min[1]) / 2 ** 0.5
    return [("slab", f"1,0,0,{cx:.4f},{0.1 * wx:.4f}"), ("diagonal", f"1,1,0,{d:.4f}")]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: a small store, few frames")
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    particles = 100_000 if args.quick else 1_000_000
    bench_particles = 50_000 if args.quick else 200_000
    frames = 12 if args.quick else 48
    work, log = open_work("slice", args.work, args.out)

    rows = []
    # --- in memory: bench ---
    small = make_store(mds, work, "porous", bench_particles, 10000, log)
    info = json.loads(sh([mds, "info", small, "--json"], log).stdout)
    for name, spec in slices_for(info["bounds_min"], info["bounds_max"]):
        for view in (0, 1, 2):
            out = os.path.join(work, f"bench_{name}_{view}.json")
            sh([mds, "bench", small, "--view", str(view), "--width", "160", "--height", "120", "--slice", spec,
                "--spp-list", "4", "--reference-spp", "4", "--coverage", "exact", "--json", out], log)
            with open(out) as f:
                j = json.load(f)
            by_mode = {r["mode"]: r for r in j["rows"]}
            culled, everything = by_mode["culled"], by_mode["all"]
            rows.append({"part": "memory", "scene": f"porous {bench_particles}", "slice": name, "spec": spec,
                         "view": view, "culled_fraction": culled["culled_fraction"],
                         "differing_pixels": culled["differing_pixels"],
                         "differing_fraction": culled["differing_fraction"], "converged": culled["converged"],
                         "gpu_ms_culled": culled["gpu_frame_ms"], "gpu_ms_all": everything["gpu_frame_ms"]})

    # --- streaming: stress ---
    store = make_store(mds, work, "porous", particles, 1000, log)
    info = json.loads(sh([mds, "info", store, "--json"], log).stdout)
    budget = info["file_bytes"] // 8
    cases = [("whole", None)] + slices_for(info["bounds_min"], info["bounds_max"])
    for name, spec in cases:
        for path in ("flythrough", "orbit", "jumps"):
            out = os.path.join(work, f"stress_{name}_{path}.json")
            cmd = [mds, "stress", store, "--gpu-budget", str(budget), "--path", path, "--frames", str(frames),
                   "--width", "320", "--height", "180", "--json", out, "-q"]
            if spec:
                cmd += ["--slice", spec]
            sh(cmd, log)
            with open(out) as f:
                j = json.load(f)
            rows.append({"part": "streaming", "scene": f"porous {particles}", "slice": name, "spec": spec or "",
                         "path": path, "budget": budget, "hit_rate": j["hit_rate"],
                         "hit_rate_over_belady": j["hit_rate_over_belady"], "bytes_read": j["bytes_read"],
                         "store_payload_bytes": j.get("store_payload_bytes", info.get("payload_bytes", 0)),
                         "nodes": j.get("nodes", 0), "nodes_never_loaded": j["nodes_never_loaded"],
                         "nodes_left_out": j["nodes_left_out"], "budget_exhausted": j["budget_exhausted"]})

    write_csv(args.out, "slice", rows, sorted({k for r in rows for k in r}))

    m = machine_info(REPO)
    md = ["# Slice benchmark (`--slice`)", "",
          f"Generated by `tools/bench_slice.py`{' --quick' if args.quick else ''} on {m['date']}; commit {m['commit']}; "
          f"{m['cpu']}, {m['nproc']} cores, {m['memory']}. One run of each row (the streaming rows are "
          "deterministic: the same cache decisions on every run; the GPU times are not).", "",
          "Slices: `slab` = `--slice 1,0,0,CX,W`, the slab a tenth of the x extent wide at the centre; `diagonal` = "
          "`--slice 1,1,0,D`, the particles with (x + y) / sqrt 2 <= D, D three quarters of the way across.", "",
          "## In memory (`mdstream bench --slice`)", "",
          f"porous {bench_particles} (node size 10000), 160x120, 4 spp, `--coverage exact`; culled = meshlets culled "
          "after convergence; pixels = pixels of the culled image beyond the 0.1 tolerance of the every-particle "
          "image of the same slice; GPU ms = the frame after convergence, culled and every meshlet.", "",
          "| slice | view | culled | pixels beyond tolerance | converged | GPU ms culled | GPU ms all |",
          "|---|---:|---:|---:|---|---:|---:|"]
    for r in rows:
        if r["part"] != "memory":
            continue
        md.append(f"| {r['slice']} (`{r['spec']}`) | {r['view']} | {100 * r['culled_fraction']:.1f} % | "
                  f"{r['differing_pixels']} ({100 * r['differing_fraction']:.3f} %) | {r['converged']} | "
                  f"{r['gpu_ms_culled']:.2f} | {r['gpu_ms_all']:.2f} |")
    md += ["", "## Streaming (`mdstream stress --slice`)", "",
           f"porous {particles} (node size 1000), pool = store / 8 = {fmt_bytes(budget)}, 320x180, {frames} frames "
           "per path, the path known to the cache. Hit rate / Belady: the online cache against the offline Belady "
           "replay of the same requests at the sizes the nodes take in the pool (a cut node: what the slice keeps "
           "of it). Never read: nodes the path never loaded; left out: of those, the nodes the slice removes "
           "whole (or that kept nothing when read).", "",
           "| slice | path | hit rate | hit rate / Belady | bytes read | never read / left out / nodes | pool held the view |",
           "|---|---|---:|---:|---:|---:|---|"]
    for r in rows:
        if r["part"] != "streaming":
            continue
        md.append(f"| {r['slice']} | {r['path']} | {r['hit_rate']:.3f} | {r['hit_rate_over_belady']:.3f} | "
                  f"{fmt_bytes(r['bytes_read'])} | {r['nodes_never_loaded']} / {r['nodes_left_out']} / "
                  f"{r['nodes'] or '-'} | {'no' if r['budget_exhausted'] else 'yes'} |")
    write_report(args.out, "slice", md)


if __name__ == "__main__":
    main()
