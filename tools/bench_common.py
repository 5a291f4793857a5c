"""Shared helpers of the benchmarks in tools/."""
import datetime
import os
import platform
import signal
import socket
import subprocess
import time


def parse_count(text):
    """'10M' -> 10000000, '4k' -> 4000, '1e6' -> 1000000."""
    text = text.strip()
    mult = {"k": 1e3, "K": 1e3, "m": 1e6, "M": 1e6, "g": 1e9, "G": 1e9}.get(text[-1:], 1)
    if mult != 1:
        text = text[:-1]
    return int(float(text) * mult)


def fmt_bytes(b):
    """1536 -> '1.50 KiB' (binary units, two decimals)."""
    for unit, s in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if b >= s:
            return f"{b / s:.2f} {unit}"
    return f"{b} B"


def _first_field(path, prefix):
    try:
        with open(path) as f:
            for line in f:
                if line.startswith(prefix):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def machine_info(repo):
    """CPU, cores, memory, kernel, date and the commit of `repo` (marked when dirty)."""
    cpu = _first_field("/proc/cpuinfo", "model name") or "unknown"
    mem_kib = _first_field("/proc/meminfo", "MemTotal")
    mem = f"{int(mem_kib.split()[0]) / 1024 / 1024:.1f} GiB" if mem_kib else "unknown"
    commit = "unknown"
    try:
        commit = subprocess.run(["git", "-C", repo, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
        # The benchmarks' own outputs (docs/results) do not make the measured code dirty.
        dirty = subprocess.run(["git", "-C", repo, "status", "--porcelain", "--untracked-files=no", "--", ".",
                                ":(exclude)docs/results"],
                               capture_output=True, text=True).stdout.strip()
        if dirty:
            commit += " (with uncommitted changes)"
    except (OSError, subprocess.CalledProcessError):
        pass
    return {"nproc": os.cpu_count(), "cpu": cpu, "memory": mem, "kernel": platform.release(),
            "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"), "commit": commit}


def newest_mdstream(repo):
    """The most recently built build*/mdstream of `repo`; exits with a message when there is none."""
    import sys
    cands = [os.path.join(repo, d, "mdstream") for d in os.listdir(repo) if d.startswith("build")]
    cands = [c for c in cands if os.path.exists(c)]
    if not cands:
        sys.exit("no build*/mdstream found; pass --mdstream")
    return max(cands, key=os.path.getmtime)


def open_work(name, work, out):
    """Creates the work folder (a temporary one when `work` is empty) and `out`; returns the work
    folder and an open log file in it."""
    import tempfile
    work = work or tempfile.mkdtemp(prefix=f"mds_{name}_")
    os.makedirs(work, exist_ok=True)
    os.makedirs(out, exist_ok=True)
    log = open(os.path.join(work, f"{name}.log"), "w")
    return work, log


def sh(cmd, log, env=None, timeout=None):
    """Runs `cmd`, appends it with its output and time to `log`; raises on a non-zero exit."""
    t0 = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    log.write(f"$ {' '.join(cmd)}  ({time.time() - t0:.1f} s, rc {r.returncode})\n{r.stdout}{r.stderr}\n")
    log.flush()
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stderr[-3000:]}")
    return r


def timed(cmd, log):
    """sh(cmd, log); returns its wall time in seconds."""
    t0 = time.perf_counter()
    sh(cmd, log)
    return time.perf_counter() - t0


def make_store(mds, work, scene, particles, node_size, log):
    """`mdstream synth` + `convert --node-size` into `work`, reused when it is already there."""
    store = os.path.join(work, f"{scene}_{particles}_{node_size}.mds")
    if os.path.exists(store):
        return store
    dump = os.path.join(work, f"{scene}_{particles}.lammpstrj")
    sh([mds, "synth", "--scene", scene, "-n", str(particles), "-q", "-o", dump], log)
    sh([mds, "convert", dump, "-o", store, "--node-size", str(node_size)], log)
    os.remove(dump)
    return store


def add_series_arguments(ap, repo, repeats, width, height):
    """The arguments the series benchmarks share: the binary, a quick smoke run, the series
    (particles per frame, frames), repeats, image size, the viewer switch, work and output folders."""
    ap.add_argument("--mdstream", default=None, help="mdstream binary (default: newest build-*/mdstream)")
    ap.add_argument("--quick", action="store_true", help="smoke run: small stores, one repeat")
    ap.add_argument("--particles", type=int, default=1_000_000)
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--repeats", type=int, default=repeats)
    ap.add_argument("--width", type=int, default=width)
    ap.add_argument("--height", type=int, default=height)
    ap.add_argument("--no-viewer", action="store_true", help="skip the viewer runs")
    ap.add_argument("--work", default="", help="work folder (default: a temporary one)")
    ap.add_argument("--out", default=os.path.join(repo, "docs", "results"))


def make_series(mds, work, scene, particles, frames, log, extra=()):
    """`mdstream synth --frames` + `convert -o SCENE.mds.series` (with `extra` convert options) into
    `work`; the index's path. The trajectory is removed."""
    traj = os.path.join(work, f"{scene}.lammpstrj")
    sh([mds, "synth", "--scene", scene, "-n", str(particles), "--frames", str(frames), "-q", "-o", traj], log)
    series = os.path.join(work, f"{scene}.mds.series")
    sh([mds, "convert", traj, "-q", *extra, "-o", series], log)
    os.remove(traj)
    return series


def differing_fraction(a, b, tol=0.1):
    """Share of pixels of two PNGs with a channel more than `tol` apart in linear RGB (the
    renderer's image comparison, render/image_compare.h)."""
    import numpy as np
    from PIL import Image

    def linear(path):
        c = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64) / 255.0
        return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)

    return float((np.abs(linear(a) - linear(b)).max(axis=2) > tol).mean())


def write_report(out, name, md):
    """Ends the report `md` (a list of lines) with the link to `name`.csv, writes it as `name`.md
    in `out` and prints its path."""
    md = md + ["", f"Raw numbers: [`{name}.csv`]({name}.csv).", ""]
    path = os.path.join(out, f"{name}.md")
    with open(path, "w") as f:
        f.write("\n".join(md))
    print(path)


def write_csv(out, name, rows, keys):
    """Writes `rows` (dicts) with the columns `keys` as `name`.csv in `out`."""
    import csv
    with open(os.path.join(out, f"{name}.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


class Xvfb:
    """An Xvfb server on a free display number; stopped on exit."""

    def __init__(self):
        self.proc = None
        for n in range(200 + os.getpid() % 500, 900):
            if os.path.exists(f"/tmp/.X{n}-lock") or os.path.exists(f"/tmp/.X11-unix/X{n}"):
                continue
            self.proc = subprocess.Popen(["Xvfb", f":{n}", "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            t0 = time.time()
            while time.time() - t0 < 15 and self.proc.poll() is None:
                s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
                try:
                    s.connect(f"/tmp/.X11-unix/X{n}")
                    self.display = f":{n}"
                    return
                except OSError:
                    time.sleep(0.05)
                finally:
                    s.close()
            self.stop()
        raise RuntimeError("Xvfb did not start")

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            self.proc.wait()
        self.proc = None
