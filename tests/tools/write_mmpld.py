#!/usr/bin/env python3
"""Small independent MMPLD writer for mdstream's tests (MegaMol particle list data 1.0-1.3).

Usage: write_mmpld.py SPEC.json OUT.mmpld EXPECTED.json [SPEC2 OUT2 EXPECTED2 ...]

SPEC: {"version": 100..103, "seed": int, "bbox": [6 floats] (optional),
       "omit_timestamp": bool (optional, emulates old MegaMol 1.3 writers),
       "frames": [{"lists": [{"vertex": 0..4, "colour": 0..7, "count": n,
                              "radius": r (global radius, vertex 1/3/4),
                              "colour_range": [lo, hi] (FLOAT_RGB(A) channels, default [0, 1))}]}]}

Layout as in MegaMol's MMPLDDataSource (header, uint64 frame table, frames of lists;
1.1 cluster info after each list, 1.2+ frame timestamp, 1.3 per-list bbox). Particle
values are random (seeded); EXPECTED gets what a reader must return per frame: x, y, z,
type (list index + 1, lists without positions skipped), radius (per particle or null),
type_radius, intensity (FLOAT_I / DOUBLE_I lists; null where a list has other colours), color
(RGBA8 as R | G << 8 | B << 16 | A << 24: float channels clamped to [0, 1] and rounded, USHORT
ones scaled by 255/65535 and rounded, RGB with alpha 255, NONE the list's global colour; null
where a list has intensities), plus byte offsets of each list's particle count field (for
corruption tests).
"""
import json
import math
import struct
import sys

import numpy as np

VERTEX_SIZE = {0: 0, 1: 12, 2: 16, 3: 6, 4: 24}
COLOUR_SIZE = {0: 0, 1: 3, 2: 4, 3: 4, 4: 12, 5: 16, 6: 8, 7: 8}


GLOBAL_COLOUR = bytes([200, 100, 50, 255])


def colour_bytes(rng, ctype, n, lo=0.0, hi=1.0):
    if ctype == 0:
        return [b""] * n
    if ctype in (1, 2):
        return [rng.integers(0, 256, size=COLOUR_SIZE[ctype], dtype=np.uint8).tobytes() for _ in range(n)]
    if ctype == 3:
        return [rng.random(1).astype("<f4").tobytes() for _ in range(n)]
    if ctype in (4, 5):
        k = COLOUR_SIZE[ctype] // 4
        return [(lo + (hi - lo) * rng.random(k)).astype("<f4").tobytes() for _ in range(n)]
    if ctype == 6:
        return [rng.integers(0, 65536, size=4, dtype=np.uint16).astype("<u2").tobytes() for _ in range(n)]
    return [rng.random(1).astype("<f8").tobytes() for _ in range(n)]  # 7 DOUBLE_I


def rgba8(ctype, c):
    """The RGBA8 a reader keeps for colour bytes c of colour type ctype (None: an intensity)."""
    if ctype == 0:
        ch = list(GLOBAL_COLOUR)
    elif ctype == 1:
        ch = list(c) + [255]
    elif ctype == 2:
        ch = list(c)
    elif ctype in (4, 5):
        v = [float(x) for x in struct.unpack("<%df" % (len(c) // 4), c)] + [1.0]
        ch = [math.floor(min(max(x, 0.0), 1.0) * 255.0 + 0.5) for x in v[:4]]
    elif ctype == 6:
        ch = [(x * 255 + 32767) // 65535 for x in struct.unpack("<4H", c)]
    else:
        return None
    return ch[0] | ch[1] << 8 | ch[2] << 16 | ch[3] << 24


def write_frame(rng, version, frame, omit_timestamp, index, base):
    out = bytearray()
    exp = {"x": [], "y": [], "z": [], "type": [], "radius": [], "type_radius": {}, "count_offsets": [],
           "intensity": [], "color": []}
    any_xyzr = any(l["vertex"] == 2 for l in frame["lists"])
    if version >= 102 and not omit_timestamp:
        out += struct.pack("<f", float(index) * 0.5)
    out += struct.pack("<I", len(frame["lists"]))
    for li, lst in enumerate(frame["lists"]):
        vt, ct, n = lst["vertex"], lst["colour"], lst["count"]
        out += struct.pack("<BB", vt, ct)
        radius = float(np.float32(lst.get("radius", 0.5)))
        if vt in (1, 3, 4):
            out += struct.pack("<f", radius)
            exp["type_radius"][str(li + 1)] = radius
        if ct == 0:
            out += GLOBAL_COLOUR
        elif ct in (3, 7):
            out += struct.pack("<ff", 0.0, 1.0)
        exp["count_offsets"].append(base + len(out))
        out += struct.pack("<Q", n)
        if vt == 0:
            pos = np.zeros((0, 3))
        elif vt == 3:
            pos = rng.integers(-32768, 32768, size=(n, 3)).astype("<i2")
        elif vt == 4:
            pos = (rng.random((n, 3)) * 200.0 - 100.0).astype("<f8")
        else:
            pos = (rng.random((n, 3)) * 200.0 - 100.0).astype("<f4")
        if version == 103:
            lo = pos.min(axis=0) if len(pos) else np.zeros(3)
            hi = pos.max(axis=0) if len(pos) else np.zeros(3)
            out += struct.pack("<6f", *[float(v) for v in lo], *[float(v) for v in hi])
        if vt != 0:
            radii = rng.random(n).astype("<f4") + np.float32(0.1) if vt == 2 else None
            cols = colour_bytes(rng, ct, n, *lst.get("colour_range", [0.0, 1.0]))
            for i in range(n):
                out += pos[i].tobytes()
                if vt == 2:
                    out += radii[i].tobytes()
                out += cols[i]
            exp["x"] += [float(v) for v in pos[:, 0]]
            exp["y"] += [float(v) for v in pos[:, 1]]
            exp["z"] += [float(v) for v in pos[:, 2]]
            exp["type"] += [li + 1] * n
            if exp["intensity"] is not None and ct in (3, 7):
                fmt = "<f" if ct == 3 else "<d"
                exp["intensity"] += [float(struct.unpack(fmt, c)[0]) for c in cols]
            else:
                exp["intensity"] = None
            if exp["color"] is not None and ct not in (3, 7):
                exp["color"] += [rgba8(ct, c) for c in cols]
            else:
                exp["color"] = None
            if any_xyzr:
                exp["radius"] += [float(v) for v in radii] if vt == 2 else [radius] * n
        if version == 101:
            blob = bytes(range(12))
            out += struct.pack("<IQ", 3, len(blob)) + blob
    if not any_xyzr:
        exp["radius"] = None
    return bytes(out), exp


def write_file(spec_path, out_path, expected_path):
    spec = json.load(open(spec_path))
    version = spec["version"]
    rng = np.random.default_rng(spec.get("seed", 1))
    bbox = spec.get("bbox", [-100.0, -100.0, -100.0, 100.0, 100.0, 100.0])
    frames = spec["frames"]
    header = b"MMPLD\0" + struct.pack("<HI", version, len(frames))
    header += struct.pack("<6f", *bbox) + struct.pack("<6f", *bbox)
    table_at = len(header)
    data_start = table_at + 8 * (len(frames) + 1)
    blobs, expected = [], []
    pos = data_start
    for k, fr in enumerate(frames):
        blob, exp = write_frame(rng, version, fr, spec.get("omit_timestamp", False), k, pos)
        blobs.append(blob)
        expected.append(exp)
        pos += len(blob)
    offsets = [data_start]
    for b in blobs:
        offsets.append(offsets[-1] + len(b))
    with open(out_path, "wb") as f:
        f.write(header)
        f.write(struct.pack("<%dQ" % len(offsets), *offsets))
        for b in blobs:
            f.write(b)
    json.dump({"bbox": [float(np.float32(v)) for v in bbox], "frames": expected, "frame_offsets": offsets,
               "table_offset": table_at}, open(expected_path, "w"))


def main():
    args = sys.argv[1:]
    if not args or len(args) % 3 != 0:
        sys.exit("usage: write_mmpld.py SPEC.json OUT.mmpld EXPECTED.json [...]")
    for i in range(0, len(args), 3):
        write_file(*args[i:i + 3])


if __name__ == "__main__":
    main()
