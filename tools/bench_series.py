#!/usr/bin/python3
"""Series benchmark (`convert -o RUN.mds.series`, docs/converter.md "Trajectories"): what a
trajectory costs to convert into a series of stores, against converting its frames one by one.

A trajectory of F frames of the ablation scene (`synth --frames F`: thermal motion and an
expanding plume) in three forms:
  series      `convert traj --frames all -o run.mds.series`: frames listed once, each
              conversion seeks to its frame (ReaderOptions::start);
  --frame K   F separate `convert traj --frame K`: each skips the K frames before its own;
  one file    F conversions of a file holding that frame alone (the floor: no skipping at all);
and the series from the gzip-compressed trajectory, which cannot be sought: the list decompresses
it once, and the frames' conversions once more, each going on in the source the frame before
left open (ReaderOptions::relay). Medians of --repeats runs, the variants alternating.

Writes docs/results/series.md and series.csv.

  /usr/bin/python3 tools/bench_series.py [--quick] [--mdstream build/mdstream]
"""
import argparse
import gzip
import os
import shutil
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_common import (fmt_bytes, machine_info, newest_mdstream, open_work, sh, timed, write_csv,  # noqa: E402
                          write_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def split_frames(traj, out_dir):
    """Each frame of the LAMMPS dump `traj` as its own file in `out_dir`; their paths in order."""
    paths, out = [], None
    with open(traj) as f:
        for line in f:
            if line.startswith("ITEM: TIMESTEP"):
                if out:
                    out.close()
                paths.append(os.path.join(out_dir, f"frame{len(paths)}.lammpstrj"))
                out = open(paths[-1], "w")
            out.write(line)
    out.close()
    return paths


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: small frames, few of them")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(REPO, "docs", "results"))
    args = ap.parse_args()
    mds = args.mdstream or newest_mdstream(REPO)
    particles = 50_000 if args.quick else 1_000_000
    frames = 3 if args.quick else 6
    repeats = 1 if args.quick else args.repeats
    work, log = open_work("series", args.work, args.out)

    traj = os.path.join(work, "traj.lammpstrj")
    sh([mds, "synth", "--scene", "ablation", "-n", str(particles), "--frames", str(frames), "-q", "-o", traj], log)
    ones = split_frames(traj, work)
    traj_gz = traj + ".gz"
    with open(traj, "rb") as src, gzip.open(traj_gz, "wb", compresslevel=1) as dst:
        shutil.copyfileobj(src, dst)
    text_bytes = os.path.getsize(traj)

    times = {"series": [], "frame_k": [], "one_file": [], "series_gz": []}
    for r in range(repeats):
        out = os.path.join(work, f"r{r}")
        os.makedirs(out, exist_ok=True)
        times["series"].append(timed([mds, "convert", traj, "-q", "-o", os.path.join(out, "s.mds.series")], log))
        times["frame_k"].append(sum(timed([mds, "convert", traj, "--frame", str(k), "-q", "-o",
                                           os.path.join(out, f"k{k}.mds")], log) for k in range(frames)))
        times["one_file"].append(sum(timed([mds, "convert", ones[k], "-q", "-o", os.path.join(out, f"one{k}.mds")], log)
                                     for k in range(frames)))
        times["series_gz"].append(timed([mds, "convert", traj_gz, "-q", "-o", os.path.join(out, "g.mds.series")], log))
        # The series' stores are the stores of --frame K, byte for byte.
        for k in range(frames):
            with open(os.path.join(out, f"s.{k:04}.mds"), "rb") as a, open(os.path.join(out, f"k{k}.mds"), "rb") as b:
                if a.read() != b.read():
                    sys.exit(f"series store {k} differs from --frame {k}")
        shutil.rmtree(out)

    med = {k: statistics.median(v) for k, v in times.items()}
    total = particles * frames
    rows = []
    names = {"series": "series (`--frames all`)", "frame_k": f"{frames} x `--frame K`",
             "one_file": f"{frames} x a file of one frame", "series_gz": "series from .gz"}
    for k in ("series", "frame_k", "one_file", "series_gz"):
        rows.append({"variant": k, "seconds": round(med[k], 3), "frames_per_s": round(frames / med[k], 3),
                     "mparticles_per_s": round(total / med[k] / 1e6, 3),
                     "over_one_file": round(med[k] / med["one_file"], 3),
                     "runs": " ".join(f"{t:.3f}" for t in times[k])})
    m = machine_info(REPO)
    md = ["# Converting a trajectory to a store series", "",
          f"`tools/bench_series.py{' --quick' if args.quick else ''}`: {frames} frames of the ablation scene "
          f"(`synth --frames {frames}`), "
          f"{particles:,} particles each ({fmt_bytes(text_bytes)} of LAMMPS text; the .gz at level 1: "
          f"{fmt_bytes(os.path.getsize(traj_gz))}). Medians of {repeats} run(s), the variants alternating.", "",
          f"Machine: {m['cpu']}, {m['nproc']} cores, {m['memory']}; commit {m['commit']}; {m['date']}.", "",
          "| variant | seconds | frames/s | M particles/s | / one-frame files |", "|---|---|---|---|---|"]
    for r in rows:
        md.append(f"| {names[r['variant']]} | {r['seconds']:.2f} | {r['frames_per_s']:.2f} | "
                  f"{r['mparticles_per_s']:.2f} | {r['over_one_file']:.2f} |")
    md += ["", "Every run checks that the series' stores equal the stores of `--frame K`, byte for byte.",
           "The series lists the frames once (headers read, atom lines counted) and seeks to each; `--frame K` "
           "counts the lines of the K frames before its own (F frames: about F^2/2 frames of newlines counted). "
           "A compressed file cannot be sought: the series decompresses it once for the list and once for the "
           "frames, each frame's conversion going on in the source the frame before left open; `--frame K` "
           "decompresses K frames before its own."]
    write_report(args.out, "series", md)
    write_csv(args.out, "series", rows, ["variant", "seconds", "frames_per_s", "mparticles_per_s", "over_one_file", "runs"])
    log.close()


if __name__ == "__main__":
    main()
