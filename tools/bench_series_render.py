#!/usr/bin/python3
"""Series rendering benchmark: what stepping from one frame of a store series to the next costs,
with the defaults -- the Vulkan pipelines kept for the process (vk/pipeline_cache.h) and, in the
viewer, the next frame preloaded while a series plays (RenderHost::preload) -- against each
switched off (MDSTREAM_PIPELINE_REUSE=0: every renderer makes its pipelines, as before the cache;
MDSTREAM_SERIES_PRELOAD=0), in one run.

A trajectory of F frames of the ablation scene (`synth --frames F`) converted to a series
(`convert -o ablation.mds.series`), then, the configurations alternating:
  render in memory   `render ablation.mds.series -o f_%04d.png --stats S`: per frame the stats'
                     setup_ms.renderer (Renderer::create: buffers, upload, pipelines, warm-up)
                     and pipelines.made; the command's wall time;
  render streaming   the same with --gpu-budget (store bytes / 8, at least 1 MiB): Renderer::create_streaming;
  viewer             `view ablation.mds.series --play-series --frame-log L` under Xvfb (skipped without
                     Xvfb): the frame log's reload_ms of each frame that stepped to the next store
                     (RenderHost::set_series_position: the store read and decoded unless preloaded,
                     the renderer made), and the time from one step to the next.
Frames after the first only (the first renderer of a process always makes its pipelines).
Medians over frames and --repeats runs. --max-iterations caps each frame's culling, so that a
frame's own rendering does not drown its setup; the setup does not depend on it.

Writes docs/results/series-render.md and series-render.csv.

  /usr/bin/python3 tools/bench_series_render.py [--quick] [--mdstream build/mdstream]
"""
import argparse
import csv
import json
import os
import shutil
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (Xvfb, add_series_arguments, fmt_bytes, machine_info, make_series, newest_mdstream,  # noqa: E402
                          open_work, sh, write_csv, write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_render(mds, series, out, env, args, budget, log):
    """One `render` of the series; (wall s, [renderer ms of frames 1..], [pipelines made per frame])."""
    stats = os.path.join(out, "stats.json")
    cmd = [mds, "render", series, "-o", os.path.join(out, "f_%04d.png"), "--width", str(args.width),
           "--height", str(args.height), "--spp", str(args.spp), "--max-iterations", str(args.max_iterations),
           "--stats", stats]
    if budget:
        cmd += ["--gpu-budget", str(budget)]
    t0 = time.perf_counter()
    sh(cmd, log, env=env)
    wall = time.perf_counter() - t0
    frames = json.load(open(stats))["frames"]
    return wall, [f["setup_ms"]["renderer"] for f in frames[1:]], [f["pipelines"]["made"] for f in frames]


def run_viewer(mds, series, out, env, args, frames, log):
    """One viewer session playing the series; the reload_ms of every step to another store and the
    times between steps."""
    flog = os.path.join(out, "frames.csv")
    # Enough displayed frames for every store once more after the first: a store refines within
    # --max-iterations culling iterations and --spp samples.
    n = (frames + 1) * (args.max_iterations + args.spp + 8)
    sh([mds, "view", series, "--play-series", "--no-hud", "--width", str(args.width), "--height", str(args.height),
        "--spp", str(args.spp), "--max-iterations", str(args.max_iterations), "--fixed-resolution",
        "--exit-after-frames", str(n), "--frame-log", flog], log, env=env, timeout=1800)
    with open(flog) as f:
        rows = list(csv.DictReader(f))
    steps = [r for r in rows if float(r["reload_ms"]) > 0]
    intervals = [float(b["t_ms"]) - float(a["t_ms"]) for a, b in zip(steps, steps[1:])]
    return [float(r["reload_ms"]) for r in steps], intervals


def med(v):
    return statistics.median(v) if v else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_series_arguments(ap, REPO, repeats=3, width=640, height=360)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--max-iterations", type=int, default=8)
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    if args.quick:
        args.particles, args.frames, args.repeats = 50_000, 3, 1
        args.width, args.height = 320, 180
    work, log = open_work("series-render", args.work, args.out)

    series = make_series(mds, work, "ablation", args.particles, args.frames, log)
    store_bytes = os.path.getsize(os.path.join(work, "ablation.0000.mds"))
    budget = max(store_bytes // 8, 1 << 20)  # a quick run's nodes need more than 1/8 of its small stores

    viewer = not args.no_viewer and shutil.which("Xvfb") is not None
    xvfb = Xvfb() if viewer else None
    # (name, kind, environment): the default first, then the switches it is compared with.
    configs = [("memory", "memory", {}), ("memory-anew", "memory", {"MDSTREAM_PIPELINE_REUSE": "0"}),
               ("streaming", "streaming", {}), ("streaming-anew", "streaming", {"MDSTREAM_PIPELINE_REUSE": "0"})]
    if viewer:
        configs += [("viewer", "viewer", {}), ("viewer-anew", "viewer", {"MDSTREAM_PIPELINE_REUSE": "0"}),
                    ("viewer-no-preload", "viewer", {"MDSTREAM_SERIES_PRELOAD": "0"})]
    results = {c[0]: {"wall": [], "setup": [], "made": [], "interval": []} for c in configs}
    try:
        for r in range(args.repeats):
            for name, kind, extra in (configs if r % 2 == 0 else configs[::-1]):
                env = dict(os.environ, **extra)
                if xvfb:
                    env["DISPLAY"] = xvfb.display
                out = os.path.join(work, f"{name}_{r}")
                os.makedirs(out, exist_ok=True)
                res = results[name]
                if kind == "viewer":
                    reloads, intervals = run_viewer(mds, series, out, env, args, args.frames, log)
                    res["setup"] += reloads
                    res["interval"] += intervals
                else:
                    wall, setup, made = run_render(mds, series, out, env, args,
                                                   budget if kind == "streaming" else 0, log)
                    res["wall"].append(wall)
                    res["setup"] += setup
                    res["made"] += made
                shutil.rmtree(out)
    finally:
        if xvfb:
            xvfb.stop()

    names = {"memory": "render, in memory", "memory-anew": "render, in memory, pipelines made anew",
             "streaming": f"render, --gpu-budget {fmt_bytes(budget)}",
             "streaming-anew": f"render, --gpu-budget {fmt_bytes(budget)}, pipelines made anew",
             "viewer": "viewer, --play-series", "viewer-anew": "viewer, pipelines made anew",
             "viewer-no-preload": "viewer, no preload (`MDSTREAM_SERIES_PRELOAD=0`)"}
    base = {"memory": "memory", "memory-anew": "memory", "streaming": "streaming", "streaming-anew": "streaming",
            "viewer": "viewer", "viewer-anew": "viewer", "viewer-no-preload": "viewer"}
    rows = []
    for name, kind, extra in configs:
        res = results[name]
        row = {"config": name, "setup_ms": round(med(res["setup"]), 1),
               "vs_default": round(med(res["setup"]) / med(results[base[name]]["setup"]), 3),
               "samples": len(res["setup"]),
               "wall_s": round(med(res["wall"]), 2) if res["wall"] else "",
               "step_interval_ms": round(med(res["interval"]), 1) if res["interval"] else "",
               "made_per_frame": " ".join(str(x) for x in res["made"][:args.frames])}
        rows.append(row)

    m = machine_info(REPO)
    md = ["# Rendering a store series: what a step to the next frame costs", "",
          f"`tools/bench_series_render.py{' --quick' if args.quick else ''}`: a series of {args.frames} frames of "
          f"the ablation scene, {args.particles:,} particles each ({fmt_bytes(store_bytes)} per store), "
          f"{args.width}x{args.height}, --spp {args.spp}, --max-iterations {args.max_iterations}. The defaults "
          f"(pipelines kept for the process, vk/pipeline_cache.h; the viewer preloading the next frame while a "
          f"series plays, RenderHost::preload) against the pipelines made anew for every renderer "
          f"(`MDSTREAM_PIPELINE_REUSE=0`, as before) and the viewer without the preload "
          f"(`MDSTREAM_SERIES_PRELOAD=0`), the configurations alternating; medians over the frames after the first "
          f"and {args.repeats} run(s).", "",
          "- setup per frame: `render --stats` `setup_ms.renderer` (Renderer::create or create_streaming: buffers, "
          "upload, pipelines, warm-up); the viewer's frame log `reload_ms` of each step (RenderHost::set_series_position: "
          "the store read and decoded unless preloaded, and the renderer made);",
          "- step interval: the viewer's time from one step to the next (the frame refining at --spp, then the step);",
          "- wall: the `render` command for all frames.", "",
          f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}; commit {m['commit']}; {m['date']}; "
          f"load average at the end {os.getloadavg()[0]:.2f}.", "",
          "| configuration | setup per frame [ms] | / default | step interval [ms] | wall [s] | pipelines made per frame |",
          "|---|---:|---:|---:|---:|---|"]
    for r in rows:
        interval = f"{r['step_interval_ms']:.1f}" if r["step_interval_ms"] != "" else "-"
        wall = f"{r['wall_s']:.2f}" if r["wall_s"] != "" else "-"
        md.append(f"| {names[r['config']]} | {r['setup_ms']:.1f} | {r['vs_default']:.2f} | {interval} | {wall} | "
                  f"{r['made_per_frame'] or '-'} |")
    md.append("")
    if not viewer:
        md += ["The viewer runs were skipped (no Xvfb, or --no-viewer).", ""]
    write_report(args.out, "series-render", md)
    keys = ["config", "setup_ms", "vs_default", "samples", "step_interval_ms", "wall_s", "made_per_frame"]
    write_csv(args.out, "series-render", rows, keys)
    log.close()


if __name__ == "__main__":
    main()
