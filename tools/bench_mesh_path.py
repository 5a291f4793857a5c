#!/usr/bin/python3
"""The task/mesh sprite path against the compute + indirect draw path, on a device that has both
(VK_EXT_mesh_shader): for each scene and default view, `mdstream render` with `--mesh-shaders on`
and `off`, culled (the defaults) and `--no-cull`, and the README's streamed close-up
(`--gpu-budget`); per pair, how many pixels differ and what each path costs (time to converge,
frame time after convergence, per-pass GPU medians).

Debian 12's lavapipe has no mesh shaders; run this with Mesa 25's (tools/mesh_lavapipe.sh), or on
a GPU that has them (tools/gpu_check.sh):

  bash tools/mesh_lavapipe.sh /usr/bin/python3 tools/bench_mesh_path.py [--quick]

Writes docs/results/mesh-path.md and mesh-path.csv.
"""
import argparse
import csv
import json
import os
import sys
import time

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import machine_info, make_store, newest_mdstream, open_work, parse_count, sh  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def render(mds, store, work, log, tag, view, args, extra):
    png = os.path.join(work, f"{tag}.png")
    stats = os.path.join(work, f"{tag}.json")
    cmd = [mds, "render", store, "-o", png, "--width", str(args.width), "--height", str(args.height),
           "--spp", str(args.spp), "--view", str(view), "--stats", stats] + extra
    sh(cmd, log)
    with open(stats) as f:
        j = json.load(f)
    j["_png"] = png
    return j


def differing(a_png, b_png, tol):
    a = np.asarray(Image.open(a_png).convert("RGB")).astype(np.int32)
    b = np.asarray(Image.open(b_png).convert("RGB")).astype(np.int32)
    d = np.abs(a - b).max(axis=2)
    return int((d > tol).sum()), int(d.max()), int(d.size)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: 100k particles, 320x180, 4 spp, one scene")
    ap.add_argument("--particles", default=None, help="particles per scene (default 1M)")
    ap.add_argument("--scenes", default=None, help="default porous,ablation")
    ap.add_argument("--views", default="0,1,2")
    ap.add_argument("--width", type=int, default=None)
    ap.add_argument("--height", type=int, default=None)
    ap.add_argument("--spp", type=int, default=None)
    ap.add_argument("--budget", default="2MiB", help="GPU budget of the streamed close-up (view 2)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    ap.add_argument("--work", default=None)
    args = ap.parse_args()
    q = args.quick
    args.particles = parse_count(args.particles) if args.particles else (100_000 if q else 1_000_000)
    args.scenes = args.scenes or ("porous" if q else "porous,ablation")
    args.width = args.width or (320 if q else 640)
    args.height = args.height or (180 if q else 360)
    args.spp = args.spp or (4 if q else 8)
    mds = args.mdstream or newest_mdstream(REPO)
    work, log = open_work("bench_mesh_path", args.work, args.out)
    print(f"bench_mesh_path: {mds}, work {work}", file=sys.stderr)
    t_start = time.time()
    rows = []
    device = None
    for scene in args.scenes.split(","):
        store = make_store(mds, work, scene, args.particles, 10000, log)
        cases = [(int(v), "culled", []) for v in args.views.split(",")]
        cases += [(int(v), "no-cull", ["--no-cull"]) for v in args.views.split(",")]
        cases += [(2, f"streamed {args.budget}", ["--gpu-budget", args.budget])]
        for view, mode, extra in cases:
            res = {}
            for path in ("on", "off"):
                tag = f"{scene}_v{view}_{mode.replace(' ', '_')}_{path}"
                res[path] = render(mds, store, work, log, tag, view, args, extra + ["--mesh-shaders", path])
            on, off = res["on"], res["off"]
            if not on.get("mesh_shader_available") or on.get("sprite_path") != "mesh":
                sys.exit(f"{on.get('device')}: no task/mesh path (run under tools/mesh_lavapipe.sh)")
            device = on.get("device")
            device_type = on.get("device_type")
            vis_route = on.get("pixel_route") == "visibility"
            n2, dmax, npx = differing(on["_png"], off["_png"], 2)
            row = {"scene": scene, "view": view, "mode": mode, "pixels": npx, "differ_2": n2, "max_diff": dmax}
            for path, j in (("mesh", on), ("compute", off)):
                row[f"{path}_wall_ms"] = j.get("wall_ms", 0.0)
                row[f"{path}_converge_ms"] = j.get("time_to_converge_ms", 0.0)
                pm = j.get("pass_ms_after_convergence") or j.get("pass_ms_median") or {}
                # Without culling every frame is alike: the sum of its passes' medians.
                row[f"{path}_frame_ms"] = j.get("frame_ms_after_convergence") or sum(pm.values())
                # The sprite passes: mesh = the task/mesh draw; compute = pre-pass + draw list + raster/draw.
                keys = ("prepass", "draw_list", "draw", "raster", "resolve")
                row[f"{path}_sprite_ms"] = sum(pm.get(k, 0.0) for k in keys)
                row[f"{path}_culled"] = j.get("meshlets_culled", 0)
                row[f"{path}_iterations"] = j.get("iterations_to_converge", 0)
                row[f"{path}_bytes_read"] = (j.get("cache") or {}).get("bytes_read", "")
            rows.append(row)
            print(f"  {scene} v{view} {mode}: differ {n2}/{npx}, frame ms mesh {row['mesh_frame_ms']:.1f} "
                  f"compute {row['compute_frame_ms']:.1f}", file=sys.stderr)
    mi = machine_info(REPO)
    with open(os.path.join(args.out, "mesh-path.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    L = ["# Task/mesh sprite path against compute + indirect draws\n",
         f"Generated by `tools/bench_mesh_path.py` in {(time.time() - t_start) / 60:.1f} min.\n",
         f"Machine: {mi['cpu']}, {mi['nproc']} cores, {mi['memory']}, kernel {mi['kernel']}; {mi['date']}; "
         f"commit {mi['commit']}. Device: {device} ({device_type}"
         + (", Mesa 25's lavapipe through `tools/mesh_lavapipe.sh`; Debian 12's Mesa 22.3 has no "
            "VK_EXT_mesh_shader" if device_type == "cpu" else "") + "). "
         + ("Both paths write the visibility buffer (small glyphs ray cast in the mesh stage or in compute; "
            "the others rasterized), and one resolve shades it.\n" if vis_route else
            "The mesh path draws into colour + depth attachments.\n"),
         f"Setup: `mdstream synth` {args.particles} particles, `convert` (nodes of 10000), `mdstream render "
         f"--width {args.width} --height {args.height} --spp {args.spp} --view V --mesh-shaders on|off`, "
         "with occlusion culling (the defaults), with `--no-cull`, and the close-up streamed through a GPU "
         f"cache of {args.budget}. *Differ* = pixels whose colour differs by more than 2/255 between the two "
         "paths' PNGs (of all pixels), *max* = the largest difference in 1/255. Times from the stats JSON: "
         "converge = `time_to_converge_ms`, frame = `frame_ms_after_convergence` (GPU), sprite passes = "
         "the medians after convergence of the passes that make and draw the sprites (mesh: `draw`, the "
         "task/mesh launch, and `prepass`, the sizing of its launch; compute: `prepass` + `draw_list` + "
         "`draw`/`raster` + `resolve`). One run each; the machine is shared.\n",
         "| scene | view | mode | differ | max | converge ms mesh / compute | frame ms mesh / compute | "
         "sprite passes ms mesh / compute | meshlets culled mesh / compute |",
         "|---|---|---|---:|---:|---|---|---|---|"]
    for r in rows:
        L.append(f"| {r['scene']} | {r['view']} | {r['mode']} | {r['differ_2']} / {r['pixels']} | {r['max_diff']} "
                 f"| {r['mesh_converge_ms']:.0f} / {r['compute_converge_ms']:.0f} "
                 f"| {r['mesh_frame_ms']:.1f} / {r['compute_frame_ms']:.1f} "
                 f"| {r['mesh_sprite_ms']:.1f} / {r['compute_sprite_ms']:.1f} "
                 f"| {r['mesh_culled']} / {r['compute_culled']} |")
    same = sum(1 for r in rows if r["differ_2"] == 0)
    ratios = [r["mesh_frame_ms"] / r["compute_frame_ms"] for r in rows if r["compute_frame_ms"] > 0]
    L.append("")
    L.append(f"Images identical within 2/255 on {same} of {len(rows)} pairs. Frame after convergence, mesh / "
             f"compute: {min(ratios):.2f}-{max(ratios):.2f}x (median {float(np.median(ratios)):.2f}x). "
             + ("On lavapipe primitive setup runs on one thread (about 1 us per primitive), so the glyphs that "
                "either path still rasterizes cost most there. " if device_type == "cpu" else "")
             + "docs/rendering.md, \"Two sprite paths, one glyph\".\n")
    L.append("Raw numbers: `mesh-path.csv`.")
    with open(os.path.join(args.out, "mesh-path.md"), "w") as f:
        f.write("\n".join(L) + "\n")
    print(f"bench_mesh_path: wrote {args.out}/mesh-path.md", file=sys.stderr)


if __name__ == "__main__":
    main()
