#!/usr/bin/python3
"""Ambient occlusion benchmark (`--ao`, docs/rendering.md "Ambient occlusion"): what it costs in
time and how many samples its noise needs, and what `--ao auto` chooses per scene.

1. `mdstream render --ao auto --stats`: the packing fraction of each synthetic scene and the
   choice.
2. `mdstream bench --no-cull --ao off|on` on the dense scenes (porous, ablation), views 0 and 2:
   the GPU frame at 1, 4 and 16 spp against the 64-spp reference of the same setting (RMSE and
   pixels beyond the renderer's 0.1 tolerance: with AO the error also holds its tap noise), run
   `--runs` times alternating off / on; medians, and the on / off ratio of the GPU frame in each
   run.

Writes docs/results/ao.md and ao.csv.

  /usr/bin/python3 tools/bench_ao.py [--quick] [--mdstream build/mdstream] [--runs 3]
"""
import argparse
import json
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import machine_info, make_store, newest_mdstream, open_work, sh, write_csv, write_report  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: small stores, one run")
    ap.add_argument("--runs", type=int, default=3, help="runs of each bench, alternating off / on")
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    particles = 50_000 if args.quick else 1_000_000
    runs = 1 if args.quick else args.runs
    width, height = (160, 90) if args.quick else (480, 270)
    spps = [1, 4, 16]
    work, log = open_work("ao", args.work, args.out)

    # 1. --ao auto per scene.
    auto_rows = []
    for scene in ("gas", "shell", "ablation", "porous"):
        store = make_store(mds, work, scene, particles, 10000, log)
        out = os.path.join(work, f"auto_{scene}.json")
        sh([mds, "render", store, "-o", os.path.join(work, f"auto_{scene}.png"), "--width", "64", "--height", "48",
            "--spp", "1", "--no-cull", "--ao", "auto", "--stats", out], log)
        with open(out) as f:
            ao = json.load(f)["ambient_occlusion"]
        auto_rows.append({"scene": scene, "packing_fraction": ao["packing_fraction"], "on": ao["on"],
                          "radius": ao["radius"]})

    # 2. Cost and noise.
    rows = []
    for scene in ("porous", "ablation"):
        store = make_store(mds, work, scene, particles, 10000, log)
        for view in (0, 2):
            per_run = {"off": [], "on": []}
            for run in range(runs):
                for ao in ("off", "on"):
                    out = os.path.join(work, f"bench_{scene}_{view}_{ao}_{run}.json")
                    sh([mds, "bench", store, "--no-cull", "--view", str(view), "--width", str(width), "--height",
                        str(height), "--spp-list", ",".join(map(str, spps)), "--reference-spp", "64", "--ao", ao,
                        "--json", out], log)
                    with open(out) as f:
                        per_run[ao].append(json.load(f))
            for ao in ("off", "on"):
                for spp in spps:
                    rs = [next(r for r in j["rows"] if r["mode"] == "all" and r["spp"] == spp) for j in per_run[ao]]
                    ratio = [next(r for r in j["rows"] if r["mode"] == "all" and r["spp"] == spp)["gpu_frame_ms"] /
                             next(r for r in k["rows"] if r["mode"] == "all" and r["spp"] == spp)["gpu_frame_ms"]
                             for j, k in zip(per_run["on"], per_run["off"])]
                    rows.append({"scene": scene, "particles": particles, "view": view, "ao": ao, "spp": spp,
                                 "applied": per_run[ao][0]["ambient_occlusion"]["on"],
                                 "gpu_frame_ms": statistics.median(r["gpu_frame_ms"] for r in rs),
                                 "gpu_frame_ms_runs": " ".join(f"{r['gpu_frame_ms']:.2f}" for r in rs),
                                 "on_over_off": statistics.median(ratio) if ao == "on" else 1.0,
                                 "rmse": statistics.median(r["rmse"] for r in rs),
                                 "differing_fraction": statistics.median(r["differing_fraction"] for r in rs),
                                 "reference_gpu_frame_ms": statistics.median(j["reference"]["gpu_frame_ms"]
                                                                             for j in per_run[ao])})

    write_csv(args.out, "ao", rows, list(rows[0].keys()))

    m = machine_info(REPO)
    md = ["# Ambient occlusion benchmark (`--ao`)", "",
          f"Generated by `tools/bench_ao.py`{' --quick' if args.quick else ''} on {m['date']}; commit {m['commit']}; "
          f"{m['cpu']}, {m['nproc']} cores, {m['memory']}; device: lavapipe (CPU).", "",
          "## What `--ao auto` chooses", "",
          f"Each synthetic scene at {particles} particles: the store's packing fraction around the average particle "
          "(from its density grid: sum over cells of n_c^2 v / V_cell / N) and the choice (on at >= 0.1); "
          "radius = 3 x the largest particle radius.", "",
          "| scene | packing fraction | `--ao auto` | radius |", "|---|---:|---|---:|"]
    for r in auto_rows:
        md.append(f"| {r['scene']} | {r['packing_fraction']:.3f} | {'on' if r['on'] else 'off'} | {r['radius']:g} |")
    md += ["", "## Cost and noise (`mdstream bench --no-cull`)", "",
           f"{width}x{height}, every particle drawn; GPU ms = the median frame of the row's spp frames (GPU "
           f"timestamps), median over {runs} run(s) alternating off / on; on/off = the median of the per-run ratios; "
           "RMSE and pixels beyond the 0.1 tolerance against the 64-spp reference of the same setting (with AO "
           "the reference holds AO too: the error is the sampling noise, AO's tap noise included).", "",
           "| scene | view | ao | spp | GPU ms | on/off | RMSE | pixels beyond 0.1 | GPU ms per run |",
           "|---|---:|---|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        md.append(f"| {r['scene']} | {r['view']} | {r['ao']}{'' if r['applied'] == (r['ao'] == 'on') else ' (!)'} | "
                  f"{r['spp']} | {r['gpu_frame_ms']:.2f} | {r['on_over_off']:.2f} | {r['rmse']:.4f} | "
                  f"{100 * r['differing_fraction']:.2f} % | {r['gpu_frame_ms_runs']} |")
    write_report(args.out, "ao", md)


if __name__ == "__main__":
    main()
