#!/usr/bin/python3
"""Streamed series benchmark: what a step to the next frame of a store series costs the GPU cache,
with the first wave carried from the frame before (`--series-first-wave prior`, the default:
the nodes of the new store whose boxes match, by IoU >= 0.5, the nodes the view before wanted,
read in one wave; docs/streaming.md "Series steps") against a cold cache (`--series-first-wave
cold`: waves from the front, as before), in one run, alternating.

Trajectories of F frames of the porous and ablation scenes (`synth --frames F`) converted to
series with nodes of <= 1000 particles; for each (scene, view, budget) `render SERIES
--gpu-budget B --view V --stats S` renders every frame to convergence (the same camera for all),
and the stats of the frames after the first give, per step:
  frames to complete   the first frame with every wanted node resident and nothing in flight
                       (the viewer holds the frame before on screen until then);
  ms to complete       the wall time from the view's start to the end of that frame;
  bytes read           compressed node bytes read for the frame's view, until it converged;
  wanted at the end    nodes the converged (or capped) view wants;
  wall                 the frame's render (convergence and --spp samples).
The images of both are compared (pixels with a channel more than 0.1 apart, the renderer's
tolerance), with each other and with an unculled in-memory render of the same frames. That render's
`--visible-reference` gives the nodes holding a visible particle, and the streamed renders'
`--node-log` the nodes each read: per step the visible nodes read and missed (never read), and
the bytes read over the visible nodes' bytes (issue 4's measure). The in-memory culled render of the
same frames is the baseline: its nodes not in O are what a cache reading by node class would read. With Xvfb, the viewer plays the porous close-up (`view --play-series`) with each, and
its frame log gives the frames held on screen after each step (`held`).

Writes docs/results/series-stream.md and series-stream.csv.

  /usr/bin/python3 tools/bench_series_stream.py [--quick] [--mdstream build/mdstream]
"""
import argparse
import csv
import json
import os
import shutil
import statistics
import sys
from collections import namedtuple

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (Xvfb, add_series_arguments, differing_fraction, fmt_bytes, machine_info,  # noqa: E402
                          make_series, newest_mdstream, open_work, sh, write_csv, write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WAVES = ("prior", "cold")


def med(v):
    return statistics.median(v) if v else float("nan")


def run_render(mds, series, out, wave, view, budget, args, log):
    stats = os.path.join(out, "stats.json")
    sh([mds, "render", series, "-o", os.path.join(out, "f_%04d.png"), "--width", str(args.width), "--height",
        str(args.height), "--view", str(view), "--gpu-budget", str(budget), "--series-first-wave", wave,
        "--node-log", os.path.join(out, "n_%04d.csv"), "--stats", stats], log, timeout=3600)
    return json.load(open(stats))["frames"]


def run_in_memory(mds, series, out, view, args, log, culled):
    """The in-memory render of every frame: unculled with the nodes holding a visible particle (the
    reference), or culled (the baseline)."""
    extra = [] if culled else ["--no-cull", "--visible-reference"]
    sh([mds, "render", series, "-o", os.path.join(out, "f_%04d.png"), "--width", str(args.width), "--height",
        str(args.height), "--view", str(view), *extra, "--node-log", os.path.join(out, "n_%04d.csv")], log,
       timeout=3600)


# Per node the payload bytes; sets of node indices: visible (--visible-reference), read (streamed:
# a read finished at least once), kept (class not O: in memory, what a cache reading by class would read).
NodeLog = namedtuple("NodeLog", "bytes visible read kept")


def node_log(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return NodeLog([int(r["payload_bytes"]) for r in rows],
                   {int(r["node"]) for r in rows if r["visible"] == "1"},
                   {int(r["node"]) for r in rows if r["reads"] not in ("", "0")},
                   {int(r["node"]) for r in rows if r["class"] not in ("", "O")})


def against_reference(want, got, image, ref_image):
    """One step's row of the reference table: `got` read (streamed) or kept (in memory) the nodes
    `read`; `want` is the unculled reference's log."""
    visible_bytes = sum(want.bytes[i] for i in want.visible)
    read_bytes = sum(got.bytes[i] for i in got.read)
    return {"visible": len(want.visible), "visible_bytes": visible_bytes,
            "visible_read": len(want.visible & got.read), "visible_missed": len(want.visible - got.read),
            "read_not_visible": len(got.read - want.visible),
            "read_over_visible": read_bytes / visible_bytes if visible_bytes else float("nan"),
            "vs_unculled": differing_fraction(image, ref_image)}


def reference_columns(s):
    """Medians over the steps `s` (dicts of against_reference) of the reference table's columns."""
    return {"visible_nodes": med([x["visible"] for x in s]),
            "visible_bytes": round(med([x["visible_bytes"] for x in s])),
            "visible_read": med([x["visible_read"] for x in s]),
            "visible_missed": med([x["visible_missed"] for x in s]),
            "read_not_visible": med([x["read_not_visible"] for x in s]),
            "read_over_visible": round(med([x["read_over_visible"] for x in s]), 3),
            "differing_vs_unculled": round(max(x["vs_unculled"] for x in s), 5)}


def run_viewer(mds, series, out, wave, view, budget, args, env, log):
    """Frames held after each step, and the time from the step to the first frame not held."""
    flog = os.path.join(out, "frames.csv")
    sh([mds, "view", series, "--play-series", "--no-hud", "--width", str(args.width), "--height", str(args.height),
        "--view", str(view), "--gpu-budget", str(budget), "--series-first-wave", wave, "--spp", "4",
        "--fixed-resolution", "--exit-after-frames", str(args.viewer_frames), "--frame-log", flog], log, env=env,
       timeout=3600)
    with open(flog) as f:
        rows = list(csv.DictReader(f))
    held, held_ms = [], []
    k = 0
    while k < len(rows):
        if float(rows[k]["reload_ms"]) > 0 and k > 0:
            t0 = float(rows[k]["t_ms"])
            n = 0
            j = k
            while j < len(rows) and rows[j]["held"] == "1":
                n += 1
                j += 1
            if j < len(rows):  # a step whose hold ended within the log
                held.append(n)
                held_ms.append(float(rows[j]["t_ms"]) - t0)
            k = j
        else:
            k += 1
    return held, held_ms


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_series_arguments(ap, REPO, repeats=1, width=320, height=180)
    ap.add_argument("--viewer-frames", type=int, default=300)
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    if args.quick:
        args.particles, args.frames, args.repeats, args.viewer_frames = 50_000, 3, 1, 120
    work, log = open_work("series-stream", args.work, args.out)

    series, store_bytes = {}, {}
    for scene in ("porous", "ablation"):
        series[scene] = make_series(mds, work, scene, args.particles, args.frames, log, ["--node-size", "1000"])
        store_bytes[scene] = os.path.getsize(os.path.join(work, f"{scene}.0000.mds"))
    # (scene, view, budget, what the budget is): close-ups at a pool that holds their view (porous: 1/8
    # of the store, as in the cache benchmark; the ablation close-up wants ~250 nodes of ~1000), the
    # front views at a pool that holds the whole store.
    cases = [("porous", 2, max(store_bytes["porous"] // 8, 64 << 10), "store / 8"),
             ("ablation", 2, int(store_bytes["ablation"] * 0.65), "store x 0.65"),
             ("ablation", 0, 4 * store_bytes["ablation"], "store x 4 (all)"),
             ("porous", 0, 4 * store_bytes["porous"], "store x 4 (all)")]
    viewer = not args.no_viewer and shutil.which("Xvfb") is not None
    rows = []
    per_step = {}  # (case index, wave) -> list of per-step dicts
    diffs = {}     # case index -> list of differing fractions (frames after the first)
    refs = {}  # (scene, view) -> folder of the unculled reference frames
    in_memory = {}  # (scene, view) -> steps of the in-memory culled render against the reference
    for scene, view, _, _ in cases:
        if (scene, view) in refs:
            continue
        ref = refs[(scene, view)] = os.path.join(work, f"{scene}_v{view}_ref")
        mem = os.path.join(work, f"{scene}_v{view}_mem")
        os.makedirs(ref, exist_ok=True)
        os.makedirs(mem, exist_ok=True)
        run_in_memory(mds, series[scene], ref, view, args, log, culled=False)
        run_in_memory(mds, series[scene], mem, view, args, log, culled=True)
        for k in range(1, args.frames):
            got = node_log(os.path.join(mem, f"n_{k:04d}.csv"))
            in_memory.setdefault((scene, view), []).append(against_reference(
                node_log(os.path.join(ref, f"n_{k:04d}.csv")), got._replace(read=got.kept),
                os.path.join(mem, f"f_{k:04d}.png"), os.path.join(ref, f"f_{k:04d}.png")))
        shutil.rmtree(mem)
    for r in range(args.repeats):
        for ci, (scene, view, budget, _) in enumerate(cases):
            ref = refs[(scene, view)]
            images = {}
            for wave in (WAVES if (r + ci) % 2 == 0 else WAVES[::-1]):
                out = os.path.join(work, f"{scene}_v{view}_{wave}_{r}")
                os.makedirs(out, exist_ok=True)
                frames = run_render(mds, series[scene], out, wave, view, budget, args, log)
                for f in frames[1:]:
                    k = f["series_frame"]
                    per_step.setdefault((ci, wave), []).append({
                        "ftc": f["frames_to_complete"], "mtc": f["ms_to_complete"], "read": f["bytes_read"],
                        "loaded": f["nodes_loaded"], "wanted": f["wanted_nodes"], "wall": f["wall_ms"],
                        "frames": f["frames"], "converged": bool(f.get("iterations_to_converge", 0)),
                        "carried": f["carried_nodes"], "prior": f["prior_wanted_nodes"],
                        **against_reference(node_log(os.path.join(ref, f"n_{k:04d}.csv")),
                                            node_log(os.path.join(out, f"n_{k:04d}.csv")),
                                            os.path.join(out, f"f_{k:04d}.png"), os.path.join(ref, f"f_{k:04d}.png"))})
                images[wave] = out
            for k in range(1, args.frames):
                diffs.setdefault(ci, []).append(differing_fraction(os.path.join(images["prior"], f"f_{k:04d}.png"),
                                                                   os.path.join(images["cold"], f"f_{k:04d}.png")))
            for wave in WAVES:
                shutil.rmtree(os.path.join(work, f"{scene}_v{view}_{wave}_{r}"))

    held = {}
    if viewer:
        xvfb = Xvfb()
        try:
            env = dict(os.environ, DISPLAY=xvfb.display)
            scene, view, budget, _ = cases[0]
            for r in range(args.repeats):
                for wave in (WAVES if r % 2 == 0 else WAVES[::-1]):
                    out = os.path.join(work, f"viewer_{wave}_{r}")
                    os.makedirs(out, exist_ok=True)
                    h, hm = run_viewer(mds, series[scene], out, wave, view, budget, args, env, log)
                    held.setdefault(wave, ([], []))
                    held[wave][0].extend(h)
                    held[wave][1].extend(hm)
                    shutil.rmtree(out)
        finally:
            xvfb.stop()

    for ci, (scene, view, budget, what) in enumerate(cases):
        for wave in WAVES:
            s = per_step[(ci, wave)]
            rows.append({
                "scene": scene, "view": view, "budget_bytes": budget, "budget": what, "first_wave": wave,
                "steps": len(s),
                "frames_to_complete": med([x["ftc"] for x in s]),
                "ms_to_complete": round(med([x["mtc"] for x in s]), 1),
                "bytes_read": round(med([x["read"] for x in s])),
                "nodes_loaded": med([x["loaded"] for x in s]),
                "wanted_at_end": med([x["wanted"] for x in s]),
                "frames": med([x["frames"] for x in s]),
                "converged_steps": sum(1 for x in s if x["converged"]),
                "wall_ms": round(med([x["wall"] for x in s]), 1),
                "carried_nodes": med([x["carried"] for x in s]),
                "prior_wanted_nodes": med([x["prior"] for x in s]),
                "differing_vs_cold": round(max(diffs.get(ci, [0.0])), 5) if wave == "prior" else "",
                **reference_columns(s),
            })
    for (scene, view), s in in_memory.items():
        rows.append({"scene": scene, "view": view, "budget": "in memory", "first_wave": "in memory, culled",
                     "steps": len(s), **reference_columns(s)})

    m = machine_info(REPO)
    md = ["# Streamed series: the first wave carried from the frame before", "",
          f"`tools/bench_series_stream.py{' --quick' if args.quick else ''}`: series of {args.frames} frames of the "
          f"porous and ablation scenes (`synth --frames {args.frames}`: thermal motion, an expanding plume), "
          f"{args.particles:,} particles each, nodes of <= 1000 ({fmt_bytes(store_bytes['porous'])} / "
          f"{fmt_bytes(store_bytes['ablation'])} per store), rendered streamed at {args.width}x{args.height} "
          f"(`render SERIES --gpu-budget B --view V --stats`, the default --spp), with `--series-first-wave "
          f"prior` (default) and `cold`, alternating, {args.repeats} run(s). Per step (the frames after the first), "
          f"medians:", "",
          "- frames / ms to complete: until the first frame with every wanted node resident and nothing in "
          "flight (`frames_to_complete`, `ms_to_complete` of `render --stats`); the viewer holds the frame before "
          "on screen until then;",
          "- bytes read: compressed node bytes read for the frame's view until it converged (or its culling "
          "reached --max-iterations: `converged` counts the steps that converged);",
          "- wanted at the end: nodes the last frame of the view wants; carried: nodes of the store matched to "
          "one the view before wanted (the first wave);",
          "- differing: the largest share over the steps of pixels of the prior image more than 0.1 from the cold "
          "one (the renderer's tolerance: 1 %).", "",
          f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}; commit {m['commit']}; {m['date']}; "
          f"load average at the end {os.getloadavg()[0]:.2f}.", "",
          "| scene, view | budget | first wave | frames to complete | ms to complete | bytes read | nodes read | "
          "wanted at the end | converged | carried / wanted before | frame wall [ms] | differing |",
          "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        if r["budget"] == "in memory":
            continue
        carried = f"{r['carried_nodes']:.0f} / {r['prior_wanted_nodes']:.0f}" if r["first_wave"] == "prior" else "-"
        diff = f"{100 * r['differing_vs_cold']:.2f} %" if r["differing_vs_cold"] != "" else "-"
        md.append(f"| {r['scene']}, view {r['view']} | {fmt_bytes(r['budget_bytes'])} ({r['budget']}) | "
                  f"{r['first_wave']} | {r['frames_to_complete']:.0f} | {r['ms_to_complete']:.0f} | "
                  f"{fmt_bytes(r['bytes_read'])} | {r['nodes_loaded']:.0f} | {r['wanted_at_end']:.0f} | "
                  f"{r['converged_steps']} / {r['steps']} | {carried} | {r['wall_ms']:.0f} | {diff} |")
    md += ["", "Against the unculled render of the same frames (`render SERIES --no-cull --visible-reference "
           "--node-log`), per step, medians: the nodes holding a visible particle and their bytes; of them, those "
           "the streamed render read and those it never read (the culling found them O first); the nodes it read "
           "that hold no visible particle; its bytes read over the visible nodes' bytes (issue 4's measure, target "
           "<= 1.25); the largest share over the steps of its pixels more than 0.1 from the unculled image. "
           "`in memory, culled` (the default render, every node resident): its nodes not in O in place of the "
           "nodes read:", "",
           "| scene, view | first wave | visible nodes | visible bytes | visible read | visible missed | "
           "read, not visible | read / visible bytes | differing from unculled |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    shown = []  # (scene, view) in the order of the cases; each one's in-memory row after its first case
    for r in rows:
        if r["budget"] != "in memory" and (r["scene"], r["view"]) not in shown:
            shown.append((r["scene"], r["view"]))
    ordered = []
    for sv in shown:
        ordered += [r for r in rows if (r["scene"], r["view"]) == sv and r["budget"] == "in memory"]
        ordered += [r for r in rows if (r["scene"], r["view"]) == sv and r["budget"] != "in memory"]
    for r in ordered:
        md.append(f"| {r['scene']}, view {r['view']} | {r['first_wave']} | {r['visible_nodes']:.0f} | "
                  f"{fmt_bytes(r['visible_bytes'])} | {r['visible_read']:.0f} | {r['visible_missed']:.0f} | "
                  f"{r['read_not_visible']:.0f} | {r['read_over_visible']:.2f} | "
                  f"{100 * r['differing_vs_unculled']:.2f} % |")
    md.append("")
    if held:
        scene, view, budget, what = cases[0]
        md += [f"The viewer (`view --play-series --gpu-budget {fmt_bytes(budget)} --view {view} --spp 4`, "
               f"{scene}, {args.width}x{args.height}, {args.viewer_frames} displayed frames): frames held on screen "
               "after each step until the new view was complete, and the time from the step to the first frame "
               "not held, medians over the steps:", "",
               "| first wave | steps | frames held | ms held |", "|---|---:|---:|---:|"]
        for wave in WAVES:
            h, hm = held.get(wave, ([], []))
            md.append(f"| {wave} | {len(h)} | {med(h):.0f} | {med(hm):.0f} |")
            rows.append({"scene": scene, "view": view, "budget_bytes": budget, "budget": what,
                         "first_wave": f"viewer-{wave}", "steps": len(h), "frames_to_complete": med(h),
                         "ms_to_complete": round(med(hm), 1)})
        md.append("")
    else:
        md += ["The viewer runs were skipped (no Xvfb, or --no-viewer).", ""]
    write_report(args.out, "series-stream", md)
    keys = ["scene", "view", "budget_bytes", "budget", "first_wave", "steps", "frames_to_complete", "ms_to_complete",
            "bytes_read", "nodes_loaded", "wanted_at_end", "frames", "converged_steps", "wall_ms", "carried_nodes",
            "prior_wanted_nodes", "differing_vs_cold", "visible_nodes", "visible_bytes", "visible_read", "visible_missed",
            "read_not_visible", "read_over_visible", "differing_vs_unculled"]
    write_csv(args.out, "series-stream", rows, keys)
    log.close()


if __name__ == "__main__":
    main()
