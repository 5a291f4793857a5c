#!/usr/bin/python3
"""What accuracy costs in time: `mdstream bench` over the porous and ablation scenes.

For each scene it makes a store (`mdstream synth` + `convert`, reused in the work dir) and runs
`mdstream bench STORE --view V --spp-list ... --reference-spp R --particle-occlusion on --json` for
each view: every row is one image, every particle drawn ("all"), with occlusion culling by meshlet
("culled") or with the particle occlusion test on top ("culled+particles"), the culled modes with
the paper's expected sample area, with exact clipping and with auto, the default, which clips the
samples of particles below 2 pixels (--coverage), at one spp, compared
with the reference (every particle at R spp). Writes docs/results/accuracy.md (tables),
accuracy.csv and accuracy.png (RMSE against the renderer's wall time per image, one line per
mode and view). Times are one run's, on a shared machine: compare rows of one table.

  /usr/bin/python3 tools/bench_accuracy.py [--particles 1M] [--width 480 --height 270]
                                           [--spp-list 1,4,16] [--reference-spp 64] [--views 0,2]
"""
import argparse
import csv
import json
import math
import os
import sys

from bench_common import machine_info, make_store, newest_mdstream, open_work, parse_count, sh

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default="")
    ap.add_argument("--particles", default="1M")
    ap.add_argument("--scenes", default="porous,ablation")
    ap.add_argument("--views", default="0,2")
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--height", type=int, default=270)
    ap.add_argument("--spp-list", default="1,4,16")
    ap.add_argument("--reference-spp", type=int, default=64)
    ap.add_argument("--work-dir", default="")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    try:
        import matplotlib
    except ImportError:
        sys.exit(f"bench_accuracy: {sys.executable} has no matplotlib; run the script with /usr/bin/python3")
    mds = args.mdstream or newest_mdstream(REPO)
    n = parse_count(args.particles)
    work, log = open_work("accuracy", args.work_dir, args.out)
    info = machine_info(REPO)
    load0 = os.getloadavg()

    results = []  # (scene, view, bench json)
    for scene in args.scenes.split(","):
        store = make_store(mds, work, scene, n, 10000, log)
        for view in [int(v) for v in args.views.split(",")]:
            out = os.path.join(work, f"{scene}_v{view}.json")
            print(f"bench_accuracy: {scene} view {view}", file=sys.stderr)
            sh([mds, "bench", store, "--view", str(view), "--width", str(args.width), "--height", str(args.height),
                "--spp-list", args.spp_list, "--reference-spp", str(args.reference_spp), "--particle-occlusion", "on",
                "--coverage", "expected,exact,auto", "--json", out], log)
            with open(out) as f:
                results.append((scene, view, json.load(f)))
    load1 = os.getloadavg()

    rows = []
    for scene, view, j in results:
        for r in j["rows"]:
            rows.append({"scene": scene, "particles": n, "view": view, "mode": r["mode"],
                         "coverage": r.get("coverage", ""), "spp": r["spp"],
                         "wall_ms": r["wall_ms"], "gpu_frame_ms": r["gpu_frame_ms"],
                         "time_to_converge_ms": r.get("time_to_converge_ms", ""),
                         "culled_fraction": r.get("culled_fraction", ""), "rmse": r["rmse"],
                         "psnr_db": r["psnr_db"] if r["psnr_db"] is not None else "inf",
                         "differing_fraction": r["differing_fraction"],
                         "reference_wall_ms": j["reference"]["wall_ms"]})
    with open(os.path.join(args.out, "accuracy.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, len(results), figsize=(4.2 * len(results), 3.6), squeeze=False)
    for ax, (scene, view, j) in zip(axes[0], results):
        for mode, cov, style in (("all", "", "o-"), ("culled", "expected", "s--"), ("culled+particles", "expected", "^:"),
                                 ("culled", "exact", "s-"), ("culled+particles", "exact", "^-"),
                                 ("culled", "auto", "d-.")):
            rs = [r for r in j["rows"] if r["mode"] == mode and r.get("coverage", "") == cov]
            if rs:
                ax.plot([r["wall_ms"] / 1000 for r in rs], [r["rmse"] for r in rs], style,
                        label=mode + (f" ({cov})" if cov else ""))
                for r in rs:
                    ax.annotate(f"{r['spp']}", (r["wall_ms"] / 1000, r["rmse"]), fontsize=7)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per image [s]")
        ax.set_ylabel("RMSE vs reference")
        ax.set_title(f"{scene} view {view}", fontsize=9)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "accuracy.png"), dpi=110)

    md = [f"# What accuracy costs in time (`mdstream bench`)", "",
          f"Generated by `tools/bench_accuracy.py` on {info['date']}.", "", "## Machine", "",
          f"- CPU: {info['cpu']} ({info['nproc']} logical cores visible); device: {results[0][2]['device']}",
          f"- memory: {info['memory']}; kernel {info['kernel']}", f"- mdstream commit: {info['commit']}",
          f"- load average (1/5/15 min) at start: {' / '.join(f'{x:.2f}' for x in load0)}; at end: "
          f"{' / '.join(f'{x:.2f}' for x in load1)}", "", "## Method", "",
          f"{args.particles} particles per scene (`mdstream synth`, `convert` with the defaults), "
          f"{args.width}x{args.height} pixels. For each view `mdstream bench` renders the reference, every particle at "
          f"{args.reference_spp} samples per pixel, then one image per row: every particle (`all`) or with the "
          "probabilistic occlusion culling of Ibrahim et al. (default parameters), at the row's spp. "
          "`culled` images are those of the converged meshlet classes (what the viewer shows once the loop has "
          "settled), `culled+particles` adds the particle occlusion test after convergence (`--particle-occlusion`). "
          "*coverage*: the area alpha_s of an occlusion sample's particle in its pixel (Sect. 4.1), `expected` = the "
          "paper's expected area, `exact` = the particle clipped against the pixel, with histograms "
          "counting every particle that can reach the pixel (`--coverage exact`), `auto` = the default: exact "
          "clipping for the samples of particles that project below 2 pixels, the expected area for larger ones, "
          "with exact's histograms (docs/culling-math.md). *wall* = the renderer's CPU wall time for the image (all passes and the read-back; not the upload), "
          "*GPU/frame* = timestamps of one frame (culled: after convergence), *converge* = time until the culling "
          "converged, *RMSE* and *PSNR* of the linear RGB against the reference, *>0.1* = pixels with a channel more "
          "than 0.1 away (the renderer's tolerance: culled renders may have at most 1 % such pixels in the tests). "
          "One run; the rows of a table share the machine's load.", "", "## Results", ""]
    for scene, view, j in results:
        ref = j["reference"]
        md += [f"### {scene}, view {view}", "",
               f"Reference: {ref['spp']} spp, {ref['wall_ms'] / 1000:.2f} s.", "",
               "| mode | coverage | spp | wall [s] | GPU/frame [ms] | converge [s] | culled | RMSE | PSNR [dB] | >0.1 |",
               "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
        for r in j["rows"]:
            culled = r["mode"] != "all"
            psnr = f"{r['psnr_db']:.2f}" if r["psnr_db"] is not None else "inf"
            cov = r.get("coverage", "") or "-"
            md.append(f"| {r['mode']} | {cov} | {r['spp']} | {r['wall_ms'] / 1000:.2f} | {r['gpu_frame_ms']:.1f} | "
                      f"{r['time_to_converge_ms'] / 1000:.2f} | {100 * r['culled_fraction']:.1f} % | " if culled else
                      f"| {r['mode']} | {cov} | {r['spp']} | {r['wall_ms'] / 1000:.2f} | {r['gpu_frame_ms']:.1f} | - | - | ")
            md[-1] += f"{r['rmse']:.5f} | {psnr} | {100 * r['differing_fraction']:.3f} % |"
        md.append("")
    md += ["Raw numbers: [`accuracy.csv`](accuracy.csv); plot: [`accuracy.png`](accuracy.png).", "",
           "![RMSE against time](accuracy.png)", ""]
    with open(os.path.join(args.out, "accuracy.md"), "w") as f:
        f.write("\n".join(md))
    print(f"bench_accuracy: wrote {os.path.join(args.out, 'accuracy.md')}", file=sys.stderr)


if __name__ == "__main__":
    main()
