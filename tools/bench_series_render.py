#!/usr/bin/python3
"""Series rendering benchmark: what stepping from one frame of a store series to the next costs,
with the Vulkan pipelines kept for the process (vk/pipeline_cache.h, the default) and made anew
for every frame's renderer (MDSTREAM_PIPELINE_REUSE=0, as before the cache), in one run.

A trajectory of F frames of the ablation scene (`synth --frames F`) converted to a series
(`convert -o run.mds.series`), then, each variant with and without reuse, alternating:
  render in memory   `render run.mds.series -o f_%04d.png --stats S`: per frame the stats'
                     setup_ms.renderer (Renderer::create: buffers, upload, pipelines, warm-up)
                     and pipelines.made; the command's wall time;
  render streaming   the same with --gpu-budget (store bytes / 8, at least 1 MiB): Renderer::create_streaming;
  viewer             `view run.mds.series --play-series --frame-log L` under Xvfb (skipped without
                     Xvfb): the frame log's reload_ms of each frame that stepped to the next store
                     (RenderHost::set_series_position: the store read and decoded, the renderer made).
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
from bench_common import Xvfb, fmt_bytes, machine_info, newest_mdstream, open_work, sh, write_csv, write_report  # noqa: E402

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
    """One viewer session playing the series; the reload_ms of every step to another store."""
    flog = os.path.join(out, "frames.csv")
    # Enough displayed frames for every store once more after the first: a store refines within
    # --max-iterations culling iterations and --spp samples.
    n = (frames + 1) * (args.max_iterations + args.spp + 8)
    sh([mds, "view", series, "--play-series", "--no-hud", "--width", str(args.width), "--height", str(args.height),
        "--spp", str(args.spp), "--max-iterations", str(args.max_iterations), "--fixed-resolution",
        "--exit-after-frames", str(n), "--frame-log", flog], log, env=env, timeout=1800)
    with open(flog) as f:
        rows = list(csv.DictReader(f))
    return [float(r["reload_ms"]) for r in rows if float(r["reload_ms"]) > 0]


def med(v):
    return statistics.median(v) if v else float("nan")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: small frames, one repeat")
    ap.add_argument("--particles", type=int, default=1_000_000)
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=360)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--max-iterations", type=int, default=8)
    ap.add_argument("--no-viewer", action="store_true", help="skip the viewer runs")
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    if args.quick:
        args.particles, args.frames, args.repeats = 50_000, 3, 1
        args.width, args.height = 320, 180
    work, log = open_work("series-render", args.work, args.out)

    traj = os.path.join(work, "traj.lammpstrj")
    sh([mds, "synth", "--scene", "ablation", "-n", str(args.particles), "--frames", str(args.frames), "-q",
        "-o", traj], log)
    series = os.path.join(work, "run.mds.series")
    sh([mds, "convert", traj, "-q", "-o", series], log)
    os.remove(traj)
    store_bytes = os.path.getsize(os.path.join(work, "run.0000.mds"))
    budget = max(store_bytes // 8, 1 << 20)  # a quick run's nodes need more than 1/8 of its small stores

    viewer = not args.no_viewer and shutil.which("Xvfb") is not None
    xvfb = Xvfb() if viewer else None
    variants = ["memory", "streaming"] + (["viewer"] if viewer else [])
    results = {(v, reuse): {"wall": [], "setup": [], "made": []} for v in variants for reuse in (1, 0)}
    try:
        for r in range(args.repeats):
            for v in variants:
                for reuse in ((1, 0) if r % 2 == 0 else (0, 1)):
                    env = dict(os.environ, MDSTREAM_PIPELINE_REUSE=str(reuse))
                    if xvfb:
                        env["DISPLAY"] = xvfb.display
                    out = os.path.join(work, f"{v}_{reuse}_{r}")
                    os.makedirs(out, exist_ok=True)
                    res = results[(v, reuse)]
                    if v == "viewer":
                        res["setup"] += run_viewer(mds, series, out, env, args, args.frames, log)
                    else:
                        wall, setup, made = run_render(mds, series, out, env, args,
                                                       budget if v == "streaming" else 0, log)
                        res["wall"].append(wall)
                        res["setup"] += setup
                        res["made"] += made
                    shutil.rmtree(out)
    finally:
        if xvfb:
            xvfb.stop()

    names = {"memory": "render, in memory (Renderer::create)",
             "streaming": f"render, --gpu-budget {fmt_bytes(budget)} (Renderer::create_streaming)",
             "viewer": "viewer, --play-series (store read + decoded + renderer: reload_ms)"}
    rows = []
    for v in variants:
        on, off = results[(v, 1)], results[(v, 0)]
        row = {"variant": v, "setup_ms_reuse": round(med(on["setup"]), 1), "setup_ms_anew": round(med(off["setup"]), 1),
               "setup_ratio": round(med(on["setup"]) / med(off["setup"]), 3), "samples": len(on["setup"])}
        if v != "viewer":
            row.update({"wall_s_reuse": round(med(on["wall"]), 2), "wall_s_anew": round(med(off["wall"]), 2),
                        "made_per_frame_reuse": " ".join(str(x) for x in on["made"][:args.frames]),
                        "made_per_frame_anew": " ".join(str(x) for x in off["made"][:args.frames])})
        rows.append(row)

    m = machine_info(REPO)
    md = ["# Rendering a store series: what a step to the next frame costs", "",
          f"`tools/bench_series_render.py{' --quick' if args.quick else ''}`: a series of {args.frames} frames of "
          f"the ablation scene, {args.particles:,} particles each ({fmt_bytes(store_bytes)} per store), "
          f"{args.width}x{args.height}, --spp {args.spp}, --max-iterations {args.max_iterations}. "
          f"Each variant with the pipelines kept for the process (vk/pipeline_cache.h, the default) and made anew "
          f"for every renderer (`MDSTREAM_PIPELINE_REUSE=0`, as before), alternating; medians over the frames after "
          f"the first and {args.repeats} run(s).", "",
          f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}; commit {m['commit']}; {m['date']}; "
          f"load average at the end {os.getloadavg()[0]:.2f}.", "",
          "| variant | setup per frame, reused [ms] | made anew [ms] | ratio | command wall, reused [s] | made anew [s] |",
          "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        wall = (f"{r['wall_s_reuse']:.2f} | {r['wall_s_anew']:.2f}" if "wall_s_reuse" in r else "- | -")
        md.append(f"| {names[r['variant']]} | {r['setup_ms_reuse']:.1f} | {r['setup_ms_anew']:.1f} | "
                  f"{r['setup_ratio']:.2f} | {wall} |")
    md += ["", "Pipelines made per frame (first run; the stats' `pipelines.made`): "
           + "; ".join(f"{r['variant']}: {r['made_per_frame_reuse']} reused vs {r['made_per_frame_anew']} anew"
                       for r in rows if "made_per_frame_reuse" in r) + ".", ""]
    if not viewer:
        md += ["The viewer runs were skipped (no Xvfb, or --no-viewer).", ""]
    write_report(args.out, "series-render", md)
    keys = ["variant", "setup_ms_reuse", "setup_ms_anew", "setup_ratio", "samples", "wall_s_reuse", "wall_s_anew",
            "made_per_frame_reuse", "made_per_frame_anew"]
    write_csv(args.out, "series-render", rows, keys)
    log.close()


if __name__ == "__main__":
    main()
