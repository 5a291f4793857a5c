#!/usr/bin/python3
"""Threshold benchmark (`--threshold`, docs/rendering.md "Thresholds" and docs/streaming.md
"Thresholds"): what a property threshold reads and costs in memory and streamed, on LAMMPS'
own output: an fcc crystal with one spherical void (tools/lammps/in.void_bench), thresholded on
the atoms' potential energy (`--threshold -6:` keeps the void's surface).

1. One view at a time (`mdstream render --threshold`), each of the three default views, in
   memory (every payload decoded, the kept atoms loaded) and streamed (`--gpu-budget`, the
   nodes whose property histogram holds no kept value never read): the process's wall time
   (load, culling to convergence, the image), bytes read, nodes, and the streamed image against
   the in-memory every-particle one (pixels beyond the 0.1 tolerance). Alternating, medians of
   --repeats runs.
2. Along camera paths (`mdstream stress --threshold`): the orbit and the fly-through with a pool
   of 1/8 of the store, the whole crystal against the threshold: hit rate against the offline
   Belady replay, bytes read, nodes left out.

Writes docs/results/threshold.md and threshold.csv.

  /usr/bin/python3 tools/bench_threshold.py [--quick] [--mdstream build/mdstream]
      [--cells 160 --radius 30 --name threshold_large]  (a larger crystal, its own report)
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (differing_fraction, fmt_bytes, machine_info, newest_mdstream, open_work,  # noqa: E402
                          parse_count, sh, timed, write_csv, write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEC = "-6:"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: a small crystal, one repeat, few frames")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cells", type=int, default=0, help="unit cells per side (default 80; --quick 24)")
    ap.add_argument("--radius", type=float, default=0, help="void radius in lattice units (default 15; --quick 5)")
    ap.add_argument("--budget", default="", help="--gpu-budget of the streamed runs (default: the store's file size / 8)")
    ap.add_argument("--name", default="threshold", help="report name: docs/results/NAME.md and NAME.csv")
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    cells, radius = (24, 5) if args.quick else (80, 15)
    cells, radius = args.cells or cells, args.radius or radius
    repeats = 1 if args.quick else args.repeats
    frames = 12 if args.quick else 48
    node_size = 2000
    width, height, spp = 640, 360, 16
    work, log = open_work("threshold", args.work, args.out)

    # --- the crystal: LAMMPS, then convert ---
    store = os.path.join(work, f"void_{cells}_{radius:g}.mds")
    if not os.path.exists(store):
        t0 = time.perf_counter()
        r = subprocess.run(["lmp", "-in", os.path.join(REPO, "tools", "lammps", "in.void_bench"), "-var",
                            "n", str(cells), "-var", "r", str(radius), "-log", "none", "-screen", "none"],
                           cwd=work, capture_output=True, text=True)
        log.write(f"lmp ({time.perf_counter() - t0:.1f} s, rc {r.returncode})\n{r.stdout}{r.stderr}\n")
        if r.returncode != 0:
            sys.exit(f"lmp failed: {r.stderr[-2000:]}")
        dump = os.path.join(work, "void.lammpstrj")
        sh([mds, "convert", dump, "-o", store, "--property", "c_pe", "--node-size", str(node_size), "-q"], log)
        os.remove(dump)
    info = json.loads(sh([mds, "info", store, "--json"], log).stdout)
    budget = info["file_bytes"] // (4 if args.quick else 8)
    budget_text = f"store / {4 if args.quick else 8}"
    if args.budget:
        budget = parse_count(args.budget)
        budget_text = f"`--budget {args.budget}`"
    with_stats = os.path.join(work, "count.json")
    sh([mds, "render", store, "--threshold", SPEC, "--no-cull", "--spp", "1", "--width", "16", "--height", "16",
        "-o", os.path.join(work, "count.png"), "--stats", with_stats], log)
    with open(with_stats) as f:
        kept = json.load(f)["particles"]

    rows = []
    look = ["--width", str(width), "--height", str(height), "--spp", str(spp), "--threshold", SPEC]
    for view in (0, 1, 2):
        ref = os.path.join(work, f"ref_{view}.png")
        sh([mds, "render", store, "--view", str(view), "--no-cull", "-o", ref, *look], log)
        times = {"memory": [], "streamed": []}
        stats = {}
        for rep in range(repeats):
            for mode in ("memory", "streamed"):
                out = os.path.join(work, f"{mode}_{view}.png")
                js = os.path.join(work, f"{mode}_{view}.json")
                cmd = [mds, "render", store, "--view", str(view), "-o", out, "--stats", js, *look]
                if mode == "streamed":
                    cmd += ["--gpu-budget", str(budget)]
                times[mode].append(timed(cmd, log))
                with open(js) as f:
                    stats[mode] = json.load(f)
        for mode in ("memory", "streamed"):
            j = stats[mode]
            streamed = mode == "streamed"
            rows.append({"part": "view", "view": view, "mode": mode, "wall_s": statistics.median(times[mode]),
                         "wall_s_all": " ".join(f"{t:.2f}" for t in times[mode]),
                         "bytes_read": j["bytes_read"] if streamed else info["payload_bytes"],
                         "nodes": info["nodes"], "nodes_read": j["nodes_loaded"] if streamed else info["nodes"],
                         "nodes_left_out": j["nodes_left_out"] if streamed else "",
                         "iterations": j["iterations"], "converged": j["converged"],
                         "budget_exhausted": j.get("budget_exhausted", False),
                         "differing_fraction": differing_fraction(ref, os.path.join(work, f"{mode}_{view}.png"))})

    for case in ("whole", "threshold"):
        for path in ("orbit", "flythrough"):
            out = os.path.join(work, f"stress_{case}_{path}.json")
            cmd = [mds, "stress", store, "--gpu-budget", str(budget), "--path", path, "--frames", str(frames),
                   "--width", "320", "--height", "180", "--json", out, "-q"]
            if case == "threshold":
                cmd += ["--threshold", SPEC]
            sh(cmd, log)
            with open(out) as f:
                j = json.load(f)
            rows.append({"part": "path", "case": case, "path": path, "budget": budget, "hit_rate": j["hit_rate"],
                         "hit_rate_over_belady": j["hit_rate_over_belady"], "bytes_read": j["bytes_read"],
                         "nodes": j.get("nodes", info["nodes"]), "nodes_never_loaded": j["nodes_never_loaded"],
                         "nodes_left_out": j["nodes_left_out"], "budget_exhausted": j["budget_exhausted"]})

    write_csv(args.out, args.name, rows, sorted({k for r in rows for k in r}))
    m = machine_info(REPO)
    md = ["# Threshold benchmark (`--threshold`)", "",
          f"Generated by `tools/bench_threshold.py`{' --quick' if args.quick else ''}"
          f"{f' --cells {cells} --radius {radius:g} --name {args.name}' if args.name != 'threshold' else ''} on {m['date']}; commit "
          f"{m['commit']}; {m['cpu']}, {m['nproc']} cores, {m['memory']}.", "",
          f"The crystal: `lmp -in tools/lammps/in.void_bench -var n {cells} -var r {radius:g}` (an fcc Lennard-Jones "
          f"crystal of {cells}^3 unit cells with one spherical void of radius {radius:g} lattice units, potential energy "
          f"at step 0), converted with `--property c_pe --node-size {node_size}`: {info['particles']:,} atoms, "
          f"{info['nodes']} nodes, {fmt_bytes(info['payload_bytes'])} of payloads. `--threshold {SPEC}` keeps "
          f"{kept:,} atoms (the void's surface).", "",
          f"## One view (`mdstream render --threshold {SPEC}`)", "",
          f"{width}x{height}, {spp} spp, each default view; in memory (the store decoded whole, the kept atoms "
          f"loaded) and streamed (`--gpu-budget {fmt_bytes(budget)}`, {budget_text}). Wall = the whole process (open, "
          f"load or stream, culling to convergence, the image), median of {repeats} alternating runs (all runs in the "
          "CSV); read = payload bytes read; pixels = share of pixels beyond the 0.1 tolerance of the in-memory "
          "every-particle image.", "",
          "| view | mode | wall s | read | nodes read / left out / nodes | iterations | pixels beyond tolerance | pool held the view |",
          "|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        if r["part"] != "view":
            continue
        md.append(f"| {r['view']} | {r['mode']} | {r['wall_s']:.2f} | {fmt_bytes(r['bytes_read'])} | "
                  f"{r['nodes_read']} / {r['nodes_left_out'] or '-'} / {r['nodes']} | {r['iterations']} | "
                  f"{100 * r['differing_fraction']:.3f} % | "
                  f"{'-' if r['mode'] == 'memory' else 'no' if r['budget_exhausted'] else 'yes'} |")
    md += ["", f"## Along paths (`mdstream stress --threshold {SPEC}`)", "",
           f"Pool = {budget_text} = {fmt_bytes(budget)}, 320x180, {frames} frames per path, the path known to the cache. "
           "Hit rate / Belady: the online cache against the offline Belady replay at the sizes the nodes take in the "
           "pool (a thinned node: what the threshold keeps of it).", "",
           "| case | path | hit rate | hit rate / Belady | bytes read | never read / left out / nodes | pool held the view |",
           "|---|---|---:|---:|---:|---:|---|"]
    for r in rows:
        if r["part"] != "path":
            continue
        md.append(f"| {r['case']} | {r['path']} | {r['hit_rate']:.3f} | {r['hit_rate_over_belady']:.3f} | "
                  f"{fmt_bytes(r['bytes_read'])} | {r['nodes_never_loaded']} / {r['nodes_left_out']} / {r['nodes']} | "
                  f"{'no' if r['budget_exhausted'] else 'yes'} |")
    write_report(args.out, args.name, md)


if __name__ == "__main__":
    main()
