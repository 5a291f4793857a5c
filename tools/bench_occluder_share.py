#!/usr/bin/python3
"""What the streaming occluder share cap (`--max-occluder-share`, docs/streaming.md "Occluder share
of a filling cache") changes: held views rendered to convergence from a cold cache
(`render --gpu-budget B --view V --stats`) and the cache benchmark's paths (`stress --path P`),
with the default share (0.5) against 1 (the default budget alone, as before the cap), alternating.

Writes docs/results/occluder-share.{md,csv}. Run: /usr/bin/python3 tools/bench_occluder_share.py
"""
import argparse
import json
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (differing_fraction, fmt_bytes, machine_info, make_store, newest_mdstream,  # noqa: E402
                          open_work, sh, write_csv, write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARES = ["0.5", "1"]


def med(v):
    v = [x for x in v if x is not None]
    return statistics.median(v) if v else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mdstream", default=None)
    ap.add_argument("--particles", type=int, default=1_000_000)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=180)
    ap.add_argument("--render-runs", type=int, default=1, help="runs per held view and share")
    ap.add_argument("--stress-runs", type=int, default=3, help="runs per path and share")
    ap.add_argument("--work", default="")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    work, log = open_work("occluder_share", args.work, args.out)
    size = ["--width", str(args.width), "--height", str(args.height)]
    stores = {s: make_store(mds, work, s, args.particles, 1000, log) for s in ("porous", "ablation")}
    rows = []
    # Held views: the pool holds every node (32 MiB) for the wide views, the close-ups as the
    # series benchmark (porous store / 8, ablation store x 0.65).
    held = [("porous", 0, "32MiB"), ("porous", 1, "32MiB"), ("ablation", 0, "32MiB"), ("ablation", 1, "32MiB"),
            ("porous", 2, str(os.path.getsize(stores["porous"]) // 8)),
            ("ablation", 2, str(int(os.path.getsize(stores["ablation"]) * 0.65)))]
    for scene, view, budget in held:
        ref = os.path.join(work, f"ref_{scene}_{view}.png")
        sh([mds, "render", stores[scene], "-o", ref, "--view", str(view), *size], log)
        for run in range(args.render_runs):
            for share in SHARES:
                png = os.path.join(work, f"held_{scene}_{view}_{share}.png")
                st = png + ".json"
                sh([mds, "render", stores[scene], "-o", png, "--view", str(view), "--gpu-budget", budget,
                    "--max-occluder-share", share, "--stats", st, *size], log)
                s = json.load(open(st))
                rows.append({"kind": "held", "scene": scene, "case": f"view {view}", "budget": budget, "share": share,
                             "run": run, "converged": s["converged"], "iterations": s["iterations"],
                             "bytes_read": s["bytes_read"], "nodes_loaded": s["nodes_loaded"],
                             "wanted_nodes": s["wanted_nodes"], "wall_ms": round(s["wall_ms"]),
                             "differing": differing_fraction(ref, png), "hit_over_belady": None, "frame_p50": None,
                             "frame_p99": None, "final_frames_to_converge": None, "final_ms_to_converge": None,
                             "occluder_budget": s["parameters"]["occluder_budget"]})
                print(rows[-1], flush=True)
    for scene in ("porous", "ablation"):
        budget = str(os.path.getsize(stores[scene]) // 8)
        for path in ("flythrough", "jumps", "orbit"):
            for run in range(args.stress_runs):
                for share in SHARES:
                    js = os.path.join(work, f"stress_{scene}_{path}_{share}.json")
                    sh([mds, "stress", stores[scene], "--gpu-budget", budget, "--path", path, "--frames", "48", "-q",
                        "--max-occluder-share", share, "--json", js, *size], log)
                    r = json.load(open(js))
                    fv = r["final_view"]
                    rows.append({"kind": "stress", "scene": scene, "case": path, "budget": budget, "share": share,
                                 "run": run, "converged": fv["converged"], "iterations": None,
                                 "bytes_read": r["bytes_read"], "nodes_loaded": r["nodes_loaded"],
                                 "wanted_nodes": None, "wall_ms": None, "differing": None,
                                 "hit_over_belady": r["hit_rate_over_belady"], "frame_p50": r["frame_ms"]["p50"],
                                 "frame_p99": r["frame_ms"]["p99"],
                                 "final_frames_to_converge": fv["frames_to_converge"],
                                 "final_ms_to_converge": fv["ms_to_converge"], "occluder_budget": None})
                    print(rows[-1], flush=True)
    keys = list(rows[0].keys())
    write_csv(args.out, "occluder-share", rows, keys)
    m = machine_info(REPO)

    def group(kind):
        out = {}
        for r in rows:
            if r["kind"] == kind:
                out.setdefault((r["scene"], r["case"], r["budget"]), {}).setdefault(r["share"], []).append(r)
        return out

    def cell(rs, key, fmt):
        v = med([r[key] for r in rs])
        return "-" if v is None else fmt(v)

    md = ["# Occluder share of a filling cache (`--max-occluder-share`)", "",
          f"`tools/bench_occluder_share.py`: {args.particles:,} particles (porous, ablation), nodes of <= 1000, "
          f"{args.width}x{args.height}, the default share 0.5 against 1 (the default budget alone: every resident "
          "meshlet drawn while the cache fills), alternating. docs/streaming.md, \"Occluder share of a filling "
          "cache\", explains the cap.", "",
          f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}; commit {m['commit']}; {m['date']}.", "",
          f"## Held views from a cold cache (`render --gpu-budget B --view V --stats`, {args.render_runs} run(s), "
          "medians)", "",
          "Differing: the share of pixels more than 0.1 from the in-memory render (the renderer's tolerance: 1 %).", "",
          "| scene, view | budget | share | converged | iterations | bytes read | nodes read | wanted at the end "
          "| wall [s] | differing |",
          "|---|---|---|---|---:|---:|---:|---:|---:|---:|"]
    for (scene, case, budget), by in group("held").items():
        for share in SHARES:
            rs = by[share]
            b = budget if not budget.isdigit() else fmt_bytes(int(budget))
            md.append(f"| {scene}, {case} | {b} | {share} | {sum(r['converged'] for r in rs)}/{len(rs)} | "
                      f"{cell(rs, 'iterations', lambda v: f'{v:.0f}')} | {cell(rs, 'bytes_read', fmt_bytes)} | "
                      f"{cell(rs, 'nodes_loaded', lambda v: f'{v:.0f}')} | "
                      f"{cell(rs, 'wanted_nodes', lambda v: f'{v:.0f}')} | "
                      f"{cell(rs, 'wall_ms', lambda v: f'{v / 1000:.1f}')} | "
                      f"{cell(rs, 'differing', lambda v: f'{100 * v:.2f} %')} |")
    md += ["", f"## Camera paths (`stress --gpu-budget store/8 --path P --frames 48`, {args.stress_runs} runs, "
           "medians)", "",
           "While the camera moves the budget is whole with either share; the cap acts on the views held at "
           "rest (the jumps' views, the paths' final view).", "",
           "| scene, path | share | hit rate / Belady | bytes read | frame p50 [ms] | p99 [ms] | "
           "final view: frames to converge | ms |",
           "|---|---|---:|---:|---:|---:|---:|---:|"]
    for (scene, case, budget), by in group("stress").items():
        for share in SHARES:
            rs = by[share]
            md.append(f"| {scene}, {case} | {share} | {cell(rs, 'hit_over_belady', lambda v: f'{v:.3f}')} | "
                      f"{cell(rs, 'bytes_read', fmt_bytes)} | {cell(rs, 'frame_p50', lambda v: f'{v:.1f}')} | "
                      f"{cell(rs, 'frame_p99', lambda v: f'{v:.1f}')} | "
                      f"{cell(rs, 'final_frames_to_converge', lambda v: f'{v:.0f}')} | "
                      f"{cell(rs, 'final_ms_to_converge', lambda v: f'{v:.0f}')} |")
    write_report(args.out, "occluder-share", md)


if __name__ == "__main__":
    main()
