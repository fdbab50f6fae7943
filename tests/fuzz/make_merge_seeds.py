#!/usr/bin/env python3
"""Writes the seeds of the merge fuzz target (tests/fuzz/seeds/merge/) from real part
images: `python3 tests/fuzz/make_merge_seeds.py ./raytracer` from the repository root.
Each seed packs parts in fuzz_merge.c's layout: byte 0 = (parts - 1) | (output format
<< 3); per part: its format (0 TGA, 1 PPM, 2 PNG), 2 bytes of length (little-endian),
the file's bytes."""
import os
import subprocess
import sys
import tempfile

FMT = {"tga": 0, "ppm": 1, "png": 2}


def render(rt, tmp, name, ext, extra):
    path = os.path.join(tmp, name + "." + ext)
    subprocess.run([rt, "-input", "scenes/feat_planes.txt", "-output", path, "-size", "7", "5"]
                   + extra, check=True, stderr=subprocess.DEVNULL)
    with open(path, "rb") as f:
        return f.read()


def pack(out_fmt, parts):
    b = bytes([(len(parts) - 1) | (FMT[out_fmt] << 3)])
    for ext, data in parts:
        b += bytes([FMT[ext], len(data) & 255, len(data) >> 8]) + data
    return b


def main():
    rt = sys.argv[1]
    out = "tests/fuzz/seeds/merge"
    os.makedirs(out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        seeds = {}
        for ext in ("tga", "ppm", "png"):
            tiles = [render(rt, tmp, "t%d" % k, ext, ["-tile", str(k), "3"]) for k in range(3)]
            seeds["tiles3_" + ext] = pack(ext, [(ext, t) for t in tiles])
            seeds["tiles3_reversed_" + ext] = pack("tga", [(ext, t) for t in reversed(tiles)])
            seeds["gap_" + ext] = pack(ext, [(ext, tiles[0]), (ext, tiles[2])])
            seeds["overlap_" + ext] = pack(ext, [(ext, tiles[0]), (ext, tiles[0]),
                                                 (ext, tiles[1]), (ext, tiles[2])])
            whole = render(rt, tmp, "whole", ext, [])
            seeds["no_region_" + ext] = pack(ext, [(ext, whole)])
        mixed = [render(rt, tmp, "m%d" % k, e, ["-tile", str(k), "3"])
                 for k, e in enumerate(("tga", "ppm", "png"))]
        seeds["tiles3_mixed"] = pack("png", list(zip(("tga", "ppm", "png"), mixed)))
        quads = [render(rt, tmp, "q%d" % k, "tga", ["-region", x, y, w, h])
                 for k, (x, y, w, h) in enumerate([("0", "0", "3", "2"), ("3", "0", "4", "2"),
                                                   ("0", "2", "7", "3")])]
        seeds["regions3_tga"] = pack("ppm", [("tga", q) for q in quads])
        other = subprocess.run([rt, "-input", "scenes/feat_planes.txt", "-output",
                                os.path.join(tmp, "o.tga"), "-size", "8", "5", "-tile", "1", "3"],
                               stderr=subprocess.DEVNULL)
        if other.returncode == 0:
            with open(os.path.join(tmp, "o.tga"), "rb") as f:
                seeds["mixed_sizes_tga"] = pack("tga", [("tga", quads[0]), ("tga", f.read())])
    for name, data in seeds.items():
        with open(os.path.join(out, name), "wb") as f:
            f.write(data)
    print("%d seeds in %s" % (len(seeds), out))


main()
