#!/usr/bin/python3
"""Conversion benchmark: speed (particles/s), peak RSS, store size and meshlet quality of `mdstream convert`.

For each scene (porous, ablation) and size N it generates the scene with `mdstream synth`,
then converts
  (a) the LAMMPS text dump  (`--format lammps`), and
  (b) the same positions as raw little-endian float32 xyz (`--format raw`; written from the
      dump by a child process, outside the timed region),
with each meshlet builder (`--meshlet-builder pcl` and `octree`), each REPEATS times, and
reports medians. Wall time is measured here; peak RSS is the converter's own VmHWM from its
--json-report (the wait4 ru_maxrss of a child also counts the memory of this Python process
at fork time, so it is recorded only as `wait4_maxrss_mib`); the report also supplies
bytes/particle, compression ratio, the maximum quantization error, the meshlet quality
(mean meshlet bounding-box diagonal / node particle spacing, mean meshlet size) and the
per-stage times. On each scene's largest raw input it also runs build/tools/meshlet_bench, the
builders alone (one thread, interleaved node by node; --builder-rounds, 0 to skip).

Writes docs/results/convert.md (table + machine info), convert.csv and convert.png
(throughput vs N). Any failed step aborts the run without writing results.

  /usr/bin/python3 tools/bench_convert.py [--build-dir build] [--sizes 1M,4M,10M] [--builders pcl,octree] [--quick]

Issue 2 targets on 2 cores: >= 5 M particles/s from LAMMPS text, >= 20 M/s from binary,
<= 7 bytes/particle.
"""
import argparse
import csv
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from bench_common import machine_info, parse_count

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET_TEXT = 5e6
TARGET_BINARY = 20e6
TARGET_BYTES = 7.0


def fmt_count(n):
    if n >= 1_000_000 and n % 1_000_000 == 0:
        return f"{n // 1_000_000}M"
    if n >= 1000 and n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


def run_measured(cmd, log):
    """Runs cmd; returns (wall s, CPU s (user+sys), peak RSS bytes) of the child. Raises on failure."""
    t0 = time.perf_counter()
    with open(log, "wb") as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        with open(log, "r", errors="replace") as f:
            tail = f.read()[-2000:]
        raise RuntimeError(f"command failed (exit {proc.returncode}): {' '.join(cmd)}\n{tail}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss * 1024  # Linux: ru_maxrss in KiB


DUMP_TO_RAW = r"""
import sys
import numpy as np
dump, raw = sys.argv[1], sys.argv[2]
with open(dump, "rb") as f:
    head = [f.readline() for _ in range(9)]
    if not head[8].startswith(b"ITEM: ATOMS id type x y z"):
        sys.exit(f"{dump}: unexpected columns: {head[8].strip()}")
    n = int(head[3])
    with open(raw, "wb") as out:
        done = 0
        while done < n:
            lines = f.readlines(64 << 20)
            if not lines:
                break
            v = np.array(b" ".join(lines).split(), dtype=np.float64).reshape(-1, 5)
            v[:, 2:5].astype("<f4").tofile(out)
            done += v.shape[0]
if done != n:
    sys.exit(f"{dump}: read {done} positions, expected {n}")
"""


def dump_to_raw(dump, raw):
    """Writes the positions of a single-frame `id type x y z` LAMMPS dump as float32 xyz.
    Runs in a child process so that this process stays small (see the RSS note above)."""
    subprocess.run([sys.executable, "-c", DUMP_TO_RAW, dump, raw], check=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build-dir", default=os.path.join(REPO, "build"), help="build folder with the mdstream binary")
    ap.add_argument("--sizes", default=None, help="comma-separated particle counts (default 1M,4M,10M)")
    ap.add_argument("--scenes", default="porous,ablation")
    ap.add_argument("--repeats", type=int, default=None, help="runs per measurement (default 3)")
    ap.add_argument("--quick", action="store_true",
                    help="small run (sizes 200k,500k, 2 repeats unless given); results go to convert_quick.*")
    ap.add_argument("--out-dir", default=os.path.join(REPO, "docs", "results"))
    ap.add_argument("--work-dir", default=None, help="folder for inputs/stores (default: a temporary folder)")
    ap.add_argument("--keep", action="store_true", help="keep the generated inputs and stores")
    ap.add_argument("--threads", type=int, default=None, help="pass --threads to convert (default: its own)")
    ap.add_argument("--builders", default="pcl,octree", help="meshlet builders to compare (default pcl,octree)")
    ap.add_argument("--builder-rounds", type=int, default=5,
                    help="rounds of build/tools/meshlet_bench (the builders alone) on each scene's largest "
                         "input; 0: skip (also skipped when the tool is not built)")
    args = ap.parse_args()
    # The raw inputs are made with numpy (in a child of this interpreter) and the plot with
    # matplotlib: both are Debian packages of /usr/bin/python3, not of every python3 on PATH.
    for module in ("numpy", "matplotlib"):
        try:
            __import__(module)
        except ImportError:
            sys.exit(f"bench_convert: {sys.executable} has no {module}; run the script with /usr/bin/python3 "
                     f"(tools/bootstrap.sh installs python3-{module})")
    args.sizes = args.sizes or ("200k,500k" if args.quick else "1M,4M,10M")
    args.repeats = args.repeats or (2 if args.quick else 3)

    exe = os.path.join(args.build_dir, "mdstream")
    if not os.access(exe, os.X_OK):
        sys.exit(f"bench_convert: {exe} not found; build first (cmake --build {args.build_dir} --target mdstream)")
    sizes = [parse_count(s) for s in args.sizes.split(",") if s]
    scenes = [s for s in args.scenes.split(",") if s]
    builders = [b for b in args.builders.split(",") if b]
    work = args.work_dir or tempfile.mkdtemp(prefix="mdstream-bench-")
    os.makedirs(work, exist_ok=True)
    info = machine_info(REPO)
    load_before = os.getloadavg()
    print(f"bench_convert: {exe}, sizes {sizes}, scenes {scenes}, {args.repeats} repeats, work dir {work}", flush=True)

    rows = []
    builder_tables = []  # (scene, n, meshlet_bench's table)
    meshlet_bench = os.path.join(args.build_dir, "tools", "meshlet_bench")
    if args.builder_rounds > 0 and not os.access(meshlet_bench, os.X_OK):
        print(f"bench_convert: {meshlet_bench} not built: no table of the builders alone", flush=True)
    try:
        for scene in scenes:
            for n in sizes:
                base = os.path.join(work, f"{scene}_{fmt_count(n)}")
                dump = base + ".dump"
                t0 = time.perf_counter()
                subprocess.run([exe, "synth", "--scene", scene, "-n", str(n), "-o", dump, "--quiet"], check=True)
                synth_s = time.perf_counter() - t0
                raw = base + ".f32"
                dump_to_raw(dump, raw)
                if n == max(sizes) and args.builder_rounds > 0 and os.access(meshlet_bench, os.X_OK):
                    out = subprocess.run([meshlet_bench, raw, *builders, "--particles", str(n), "--rounds",
                                          str(args.builder_rounds)], check=True, capture_output=True, text=True).stdout
                    table = "\n".join(l for l in out.splitlines() if l.startswith("|"))
                    builder_tables.append((scene, n, table))
                    print(out, flush=True)
                for (kind, path, fmt), builder in ((k, b) for k in (("lammps text", dump, "lammps"),
                                                                     ("raw float32", raw, "raw")) for b in builders):
                    walls, cpus, rsses, reports = [], [], [], []
                    for rep in range(args.repeats):
                        tag = f"{fmt}.{builder}"
                        store = base + f".{tag}.mds"
                        report = base + f".{tag}.{rep}.json"
                        cmd = [exe, "convert", path, "-o", store, "--format", fmt, "--meshlet-builder", builder,
                               "--json-report", report, "--quiet"]
                        if args.threads:
                            cmd += ["--threads", str(args.threads)]
                        wall, cpu, rss = run_measured(cmd, base + f".{tag}.{rep}.log")
                        with open(report) as f:
                            r = json.load(f)
                        if r.get("particles") != n:
                            raise RuntimeError(f"{report}: converted {r.get('particles')} particles, expected {n}")
                        walls.append(wall)
                        cpus.append(cpu)
                        rsses.append(rss)
                        reports.append(r)
                        os.remove(store)
                    wall = statistics.median(walls)
                    last = reports[-1]
                    def med(key):
                        return round(statistics.median(r["seconds"][key] for r in reports), 4)
                    row = {
                        "scene": scene,
                        "particles": n,
                        "input": kind,
                        "meshlet_builder": builder,
                        "input_bytes": os.path.getsize(path),
                        "wall_s_median": round(wall, 4),
                        "wall_s_min": round(min(walls), 4),
                        "wall_s_max": round(max(walls), 4),
                        "particles_per_s": round(n / wall),
                        "cpu_s_median": round(statistics.median(cpus), 4),
                        "particles_per_cpu_s": round(n / statistics.median(cpus)),
                        "reported_particles_per_s": round(statistics.median(r["particles_per_second"] for r in reports)),
                        "peak_rss_mib": round(statistics.median(r["peak_rss_bytes"] for r in reports) / 2**20, 1),
                        "wait4_maxrss_mib": round(statistics.median(rsses) / 2**20, 1),
                        "bytes_per_particle": round(last["bytes_per_particle"], 4),
                        "compression_ratio": round(last["compression_ratio"], 4),
                        "max_quantization_error": last["max_quantization_error"],
                        "max_error_over_half_step": last.get("max_error_over_half_step", float("nan")),
                        "nodes": last["nodes"],
                        "meshlets": last["meshlets"],
                        "meshlet_mean_size": round(last["meshlet_quality"]["mean_size"], 3),
                        "meshlet_diag_over_spacing": round(last["meshlet_quality"]["diag_over_spacing"], 3),
                        "read_s": med("read"),
                        "sort_s": med("sort"),
                        "build_s": med("build"),
                        "gather_cpu_s": med("gather_cpu"),
                        "meshlets_cpu_s": med("meshlets_cpu"),
                        "encode_cpu_s": med("encode_cpu"),
                        "finish_s": med("finish"),
                        "synth_s": round(synth_s, 3),
                        "repeats": args.repeats,
                    }
                    rows.append(row)
                    print(f"  {scene:9s} {fmt_count(n):>5s} {kind:12s} {builder:6s} {row['particles_per_s'] / 1e6:7.2f} M/s "
                          f"(walls {', '.join(f'{w:.2f}' for w in walls)} s)  RSS {row['peak_rss_mib']:.0f} MiB  "
                          f"{row['bytes_per_particle']:.3f} B/particle  meshlets {row['meshlet_mean_size']:.2f} "
                          f"x {row['meshlet_diag_over_spacing']:.2f}  max err {row['max_quantization_error']:.3g}",
                          flush=True)
                if not args.keep:
                    os.remove(dump)
                    os.remove(raw)
    finally:
        if not args.keep and args.work_dir is None:
            shutil.rmtree(work, ignore_errors=True)
    load_after = os.getloadavg()
    write_results(args, rows, info, load_before, load_after, builder_tables)


def builders_of(rows):
    seen = []
    for r in rows:
        if r["meshlet_builder"] not in seen:
            seen.append(r["meshlet_builder"])
    return seen


def write_results(args, rows, info, load_before, load_after, builder_tables=()):
    os.makedirs(args.out_dir, exist_ok=True)
    stem = "convert_quick" if args.quick else "convert"
    csv_path = os.path.join(args.out_dir, stem + ".csv")
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)

    png_path = os.path.join(args.out_dir, stem + ".png")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (scene, kind, builder) in sorted({(r["scene"], r["input"], r["meshlet_builder"]) for r in rows}):
        pts = sorted((r["particles"], r["particles_per_s"]) for r in rows
                     if r["scene"] == scene and r["input"] == kind and r["meshlet_builder"] == builder)
        ax.plot([p[0] for p in pts], [p[1] / 1e6 for p in pts], marker="o" if builder == "pcl" else "s",
                linestyle="-" if kind.startswith("lammps") else "--", label=f"{scene}, {kind}, {builder}")
    ax.axhline(TARGET_TEXT / 1e6, color="gray", linewidth=0.8, linestyle=":")
    ax.axhline(TARGET_BINARY / 1e6, color="gray", linewidth=0.8, linestyle="-.")
    ax.set_xscale("log")
    ax.set_xlabel("particles")
    ax.set_ylabel("conversion throughput [M particles/s]")
    ax.set_title(f"mdstream convert ({info['nproc']} cores; targets: text 5 M/s, binary 20 M/s)")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)

    md_path = os.path.join(args.out_dir, stem + ".md")
    lines = []
    lines.append("# Conversion benchmark (`mdstream convert`)\n")
    lines.append(f"Generated by `tools/bench_convert.py{' --quick' if args.quick else ''}` on {info['date']}.\n")
    lines.append("## Machine\n")
    lines.append(f"- CPU: {info['cpu']} ({info['nproc']} logical cores visible)")
    lines.append(f"- memory: {info['memory']}; kernel {info['kernel']}")
    lines.append(f"- mdstream commit: {info['commit']}")
    lines.append(f"- load average (1/5/15 min) at start: {load_before[0]:.2f} / {load_before[1]:.2f} / {load_before[2]:.2f}; "
                 f"at end: {load_after[0]:.2f} / {load_after[1]:.2f} / {load_after[2]:.2f} "
                 f"(a load above the core count means other processes shared the CPU and the throughput is understated)\n")
    lines.append("## Method\n")
    lines.append("Inputs are generated with `mdstream synth` (scenes `porous` and `ablation`). Each input is converted "
                 f"{args.repeats} times with `mdstream convert IN -o OUT.mds --format lammps|raw --meshlet-builder pcl|octree "
                 "--json-report R.json --quiet` "
                 "(default node size 10000, meshlet size 16, memory budget 2 GiB); the table shows medians. "
                 "Throughput = particles / wall time of the whole command (reading, sorting, meshlets, "
                 "quantization, compression, density volume, writing), measured by the script; CPU = user + system "
                 "time of the child (all its threads); peak RSS = the converter's VmHWM (its JSON report). "
                 "Binary input = the same positions as raw little-endian float32 xyz (12 bytes/particle, one "
                 "type), written from the dump outside the timed region. bytes/particle = store size / "
                 "particles; max quantization error in length units (`err/half-step` <= 1 is the requirement). "
                 "Meshlet quality: `diag/spacing` = mean over meshlets of the meshlet's bounding-box diagonal divided "
                 "by its node's mean particle spacing (V / n)^(1/d), V the node box volume over its d non-flat axes (lower = more compact), "
                 "`size` = mean particles per meshlet (capacity 16). Stage columns (medians, from the report): read = "
                 "parse + validate (wall), sort = Morton keys + radix sort (wall), meshlets / encode = CPU seconds "
                 "summed over the worker threads.\n")
    lines.append("## Results\n")
    lines.append("| scene | N | input | meshlets | particles/s | wall [s] (min-max) | CPU [s] | peak RSS [MiB] | bytes/particle | "
                 "meshlet size | diag/spacing | read [s] | sort [s] | meshlets CPU [s] | encode CPU [s] | err/half-step |")
    lines.append("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        lines.append(f"| {r['scene']} | {fmt_count(r['particles'])} | {r['input']} | {r['meshlet_builder']} | "
                     f"{r['particles_per_s'] / 1e6:.2f} M | {r['wall_s_median']:.2f} ({r['wall_s_min']:.2f}-{r['wall_s_max']:.2f}) | "
                     f"{r['cpu_s_median']:.2f} | "
                     f"{r['peak_rss_mib']:.0f} | {r['bytes_per_particle']:.3f} | {r['meshlet_mean_size']:.2f} | "
                     f"{r['meshlet_diag_over_spacing']:.2f} | {r['read_s']:.2f} | {r['sort_s']:.2f} | "
                     f"{r['meshlets_cpu_s']:.2f} | {r['encode_cpu_s']:.2f} | {r['max_error_over_half_step']:.4f} |")
    lines.append("")
    lines.append("## Against the targets of issue 2 (2 cores)\n")
    def verdict(ok):
        return "met" if ok else "**not met**"

    def where_met(rs, target):  # " (at every size)" or the runs that reach the target
        hits = [r for r in rs if r["particles_per_s"] >= target]
        if len(hits) == len(rs):
            return " (at every size)"
        if not hits:
            return " (at no size)"
        return " (reached on " + ", ".join(f"{r['scene']} {r['particles'] // 1000000}M" for r in hits) + f"; {len(hits)} of {len(rs)})"
    for builder in sorted({r["meshlet_builder"] for r in rows}):
        text = [r for r in rows if r["input"].startswith("lammps") and r["meshlet_builder"] == builder]
        binary = [r for r in rows if not r["input"].startswith("lammps") and r["meshlet_builder"] == builder]
        if text:
            best = max(r["particles_per_s"] for r in text)
            worst = min(r["particles_per_s"] for r in text)
            lines.append(f"- `{builder}` meshlets, LAMMPS text >= 5 M particles/s: {worst / 1e6:.2f}-{best / 1e6:.2f} M/s, "
                         f"{verdict(worst >= TARGET_TEXT)}{where_met(text, TARGET_TEXT)}")
        if binary:
            best = max(r["particles_per_s"] for r in binary)
            worst = min(r["particles_per_s"] for r in binary)
            lines.append(f"- `{builder}` meshlets, binary >= 20 M particles/s: {worst / 1e6:.2f}-{best / 1e6:.2f} M/s, "
                         f"{verdict(worst >= TARGET_BINARY)}{where_met(binary, TARGET_BINARY)}")
    bmax = max(r["bytes_per_particle"] for r in rows)
    lines.append(f"- <= 7 bytes/particle: at most {bmax:.3f}, {verdict(bmax <= TARGET_BYTES)}")
    emax = max(r["max_error_over_half_step"] for r in rows)
    lines.append(f"- quantization error <= half a step: max ratio {emax:.6f}, {verdict(emax <= 1.0 + 1e-6)}")
    lines.append("")
    if builder_tables:
        lines.append("## The meshlet builders alone\n")
        lines.append(f"`build/tools/meshlet_bench INPUT.f32 {' '.join(builders_of(rows))} --particles N --rounds "
                     f"{args.builder_rounds}` on each scene's largest raw input (tools/meshlet_bench.cpp): the "
                     "builders on the converter's nodes, interleaved node by node on one thread, thread CPU time "
                     "per particle, medians over the rounds; the quality columns as above.\n")
        for scene, n, table in builder_tables:
            lines.append(f"{scene} {fmt_count(n)}:\n")
            lines.append(table + "\n")
    lines.append(f"Raw numbers: [`{os.path.basename(csv_path)}`]({os.path.basename(csv_path)}); "
                 f"plot: [`{os.path.basename(png_path)}`]({os.path.basename(png_path)}).\n")
    lines.append(f"![throughput vs N]({os.path.basename(png_path)})\n")
    with open(md_path, "w") as f:
        f.write("\n".join(lines))
    print(f"bench_convert: wrote {md_path}, {csv_path}, {png_path}")


if __name__ == "__main__":
    main()
