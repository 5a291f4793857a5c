#!/usr/bin/python3
"""Classification benchmark: variants of the classification passes (shaders/cull_classify.comp) in
the frames of `mdstream stress` where they cost most: fly-throughs and jumps of the porous and
ablation scenes with a GPU budget of 1/8 of the store. Variants (--variants, default
shared,subgroup):
  thread    one thread per box (MDSTREAM_CULL_COOP_BOXES=0)
  shared    cull_classify_coop.comp (MDS_COOPERATIVE_BOXES): a box test of more than
            kCooperativeTexels pyramid texels is run by its whole subgroup, nodes one thread each
            in a 64-node workgroup (MDSTREAM_CULL_NODE_SUBGROUP=0)
  subgroup  the same, but every node tested by a subgroup of its own (push.mode 2)
  cells     subgroup, and a shared test's occupied cells one after the other, each cell's texels
            over the subgroup (kSharedCells, MDSTREAM_CULL_SHARED_CELLS=1; the default where box
            tests are shared, since the H200's run 13; the other variants set it to 0)
They run alternately, --reps times each; the table shows medians over the runs, with the node and
meshlet passes (`classify_nodes`, `classify_meshlets`) apart. The variants must classify alike: the
script checks that every frame's hits, misses and reads are the same (column *same demand*).

Writes docs/results/classify.md and classify.csv (or --out).

  /usr/bin/python3 tools/bench_classify.py [--quick] [--mdstream build/mdstream]
"""
import argparse
import csv
import json
import os
import shutil
import statistics as st
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import machine_info, make_store, newest_mdstream, open_work, sh  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def quantile(v, q):
    s = sorted(v)
    if not s:
        return 0.0
    x = q * (len(s) - 1)
    i = int(x)
    return s[i] if i + 1 >= len(s) else s[i] + (s[i + 1] - s[i]) * (x - i)


VARIANT_ENV = {
    "thread": {"MDSTREAM_CULL_COOP_BOXES": "0"},
    "shared": {"MDSTREAM_CULL_COOP_BOXES": "1", "MDSTREAM_CULL_NODE_SUBGROUP": "0", "MDSTREAM_CULL_SHARED_CELLS": "0"},
    "subgroup": {"MDSTREAM_CULL_COOP_BOXES": "1", "MDSTREAM_CULL_NODE_SUBGROUP": "1", "MDSTREAM_CULL_SHARED_CELLS": "0"},
    "cells": {"MDSTREAM_CULL_COOP_BOXES": "1", "MDSTREAM_CULL_NODE_SUBGROUP": "1", "MDSTREAM_CULL_SHARED_CELLS": "1"},
}


def run(mds, store, path, variant, args, work, log, rep):
    out = os.path.join(work, f"{os.path.basename(store)}.{path}.{variant}.{rep}.json")
    env = dict(os.environ, MDSTREAM_CULL_COOP_TEXELS=str(args.texels), **VARIANT_ENV[variant])
    budget = os.path.getsize(store) // 8
    sh([mds, "stress", store, "--gpu-budget", str(budget), "--path", path, "--frames", str(args.frames),
        "--width", str(args.width), "--height", str(args.height), "--settle-frames", "0", "--json", out, "-q"],
       log, env=env)
    with open(out) as f:
        j = json.load(f)
    pf = j["per_frame"]
    n = j["frames"]
    nodes = [g.get("classify_nodes", 0.0) for g in pf["gpu_passes"][:n]]
    meshlets = [g.get("classify_meshlets", 0.0) for g in pf["gpu_passes"][:n]]
    classify = [a + b for a, b in zip(nodes, meshlets)]
    return {
        "device": j.get("device", "unknown"),
        "shared": j.get("cull_shared_box_tests", False),
        "node_per_subgroup": j.get("cull_node_per_subgroup", False),
        "shared_cells": j.get("cull_shared_cells", False),
        "classify_sum": sum(classify),
        "nodes_sum": sum(nodes),
        "meshlets_sum": sum(meshlets),
        "classify_p50": quantile(classify, 0.5),
        "classify_max": max(classify) if classify else 0.0,
        "gpu_p50": quantile(pf["gpu_ms"][:n], 0.5),
        "gpu_p99": quantile(pf["gpu_ms"][:n], 0.99),
        "wall_p50": j["frame_ms"]["p50"],
        "wall_p99": j["frame_ms"]["p99"],
        "demand": [pf[k][:n] for k in ("hits", "misses", "reads_requested")],
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: small stores, few frames")
    ap.add_argument("--particles", type=int, default=None, help="particles per scene (default 1.5M; quick 100k)")
    ap.add_argument("--node-size", type=int, default=2000)
    ap.add_argument("--frames", type=int, default=None, help="frames per path (default 120; quick 16)")
    ap.add_argument("--width", type=int, default=None, help="default 640 (quick 160)")
    ap.add_argument("--height", type=int, default=None, help="default 360 (quick 90)")
    ap.add_argument("--reps", type=int, default=None, help="runs per variant (default 3; quick 1)")
    ap.add_argument("--texels", type=int, default=256, help="MDSTREAM_CULL_COOP_TEXELS (kCooperativeTexels)")
    ap.add_argument("--variants", default="shared,subgroup", help="of thread, shared, subgroup, cells; the first is the base")
    ap.add_argument("--scenes", default="porous,ablation")
    ap.add_argument("--paths", default="flythrough,jumps")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    ap.add_argument("--work", default=None, help="scratch folder (default: a temporary one, removed)")
    args = ap.parse_args()
    q = args.quick
    args.particles = args.particles or (100_000 if q else 1_500_000)
    args.frames = args.frames or (16 if q else 120)
    args.width = args.width or (160 if q else 640)
    args.height = args.height or (90 if q else 360)
    args.reps = args.reps or (1 if q else 3)
    mds = args.mdstream or newest_mdstream(REPO)
    work, log = open_work("bench_classify", args.work, args.out)
    t0 = time.time()
    variants = args.variants.split(",")
    for v in variants:
        if v not in VARIANT_ENV:
            ap.error(f"--variants: unknown variant '{v}' (thread, shared, subgroup, cells)")
    rows = []
    device = "unknown"
    try:
        for scene in args.scenes.split(","):
            store = make_store(mds, work, scene, args.particles, args.node_size, log)
            for path in args.paths.split(","):
                runs = {v: [] for v in variants}
                for rep in range(args.reps):
                    for variant in variants:
                        runs[variant].append(run(mds, store, path, variant, args, work, log, rep))
                device = runs[variants[0]][0]["device"]
                if any(v != "thread" and not runs[v][0]["shared"] for v in variants):
                    print("bench_classify: the device has no subgroup ballot + shuffle + add: nothing to compare")
                    return 0
                for v in variants:  # the variant's settings took effect
                    if runs[v][0]["shared_cells"] != (v == "cells"):
                        raise SystemExit(f"bench_classify: variant {v} ran with shared cells {runs[v][0]['shared_cells']}")
                # Demand equal within each variant (reads that may or may not arrive within a
                # frame make it vary between runs on a fast device), then across the variants.
                steady = all(r["demand"] == rs[0]["demand"] for rs in runs.values() for r in rs)
                same = ("yes" if all(rs[0]["demand"] == runs[variants[0]][0]["demand"] for rs in runs.values())
                        else "**no**") if steady else "varies between runs"
                for variant, rs in runs.items():
                    row = {"scene": scene, "path": path, "variant": variant, "same_demand": same}
                    for k in ("classify_sum", "nodes_sum", "meshlets_sum", "classify_p50", "classify_max", "gpu_p50",
                              "gpu_p99", "wall_p50", "wall_p99"):
                        row[k] = st.median(r[k] for r in rs)
                    rows.append(row)
                    print(f"{scene} {path} {variant}: classify {row['classify_sum']:.1f} ms over the path "
                          f"(nodes {row['nodes_sum']:.1f}, meshlets {row['meshlets_sum']:.1f}), "
                          f"max {row['classify_max']:.2f}; GPU frame p50/p99 {row['gpu_p50']:.2f}/{row['gpu_p99']:.2f}",
                          flush=True)
    finally:
        log.close()
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "classify.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    m = machine_info(REPO)
    L = ["# The classification passes: shared box tests, a subgroup per node", "",
         f"Generated by `tools/bench_classify.py` in {(time.time() - t0) / 60:.1f} min.", "",
         f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}, kernel {m['kernel']}; {m['date']}; "
         f"commit {m['commit']}. Device: {device}.", "",
         f"Setup: `mdstream synth --scene S -n {args.particles}`, `convert --node-size {args.node_size}`; "
         f"`mdstream stress --path P --frames {args.frames}` at {args.width}x{args.height}, GPU budget = store / 8, "
         f"the occlusion policy. *thread* = one thread per box (`MDSTREAM_CULL_COOP_BOXES=0`), *shared* = "
         f"box tests of more than {args.texels} texels run by their subgroup (`=1`), nodes one thread each "
         "(`MDSTREAM_CULL_NODE_SUBGROUP=0`), *subgroup* = the same with a subgroup per node, "
         "*cells* = subgroup with a shared test's occupied cells one after the other, "
         "each cell's texels over the subgroup (`MDSTREAM_CULL_SHARED_CELLS=1`, the default where box tests are "
         f"shared; the other variants set it to 0). {args.reps} runs per variant, "
         "alternating; medians. *classify* = GPU ms of the classification passes summed over "
         "the path's frames (*nodes* and *meshlets*: each pass's sum), and the largest frame's; GPU frame = the "
         "frame's timestamped passes; wall = CPU wall "
         "time of the frame (`frame_ms`). *Same demand* = every frame's hits, misses and reads equal in every run "
         "of every variant (*varies between runs*: already between the runs of one variant, as on a fast "
         "device where a read may or may not arrive within a frame; the classes themselves are compared by "
         "`RenderCli.SharedBoxTestsClassifyLikeOneThreadPerBox`).", "",
         "| scene | path | variant | classify ms (sum) | nodes | meshlets | classify max ms | GPU frame p50 / p99 ms | wall p50 / p99 ms | same demand |",
         "|---|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        L.append(f"| {r['scene']} | {r['path']} | {r['variant']} | {r['classify_sum']:.1f} | {r['nodes_sum']:.1f} | "
                 f"{r['meshlets_sum']:.1f} | {r['classify_max']:.2f} | "
                 f"{r['gpu_p50']:.2f} / {r['gpu_p99']:.2f} | {r['wall_p50']:.2f} / {r['wall_p99']:.2f} | "
                 f"{r['same_demand']} |")
    nv = len(variants)
    for v in variants[1:]:
        L += ["", f"{v} / {variants[0]} (same run):", ""]
        L.append("| scene | path | classify sum | nodes sum | classify max | GPU frame p50 | GPU frame p99 | wall p99 |")
        L.append("|---|---|---:|---:|---:|---:|---:|---:|")
        for k0 in range(0, len(rows), nv):
            a, b = rows[k0], rows[k0 + variants.index(v)]

            def ratio(k):
                return f"{b[k] / a[k]:.2f}" if a[k] > 0 else "-"
            L.append(f"| {a['scene']} | {a['path']} | {ratio('classify_sum')} | {ratio('nodes_sum')} | "
                     f"{ratio('classify_max')} | {ratio('gpu_p50')} | {ratio('gpu_p99')} | {ratio('wall_p99')} |")
    with open(os.path.join(args.out, "classify.md"), "w") as f:
        f.write("\n".join(L) + "\n")
    print("wrote", os.path.join(args.out, "classify.md"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
