#!/usr/bin/env python3
"""Counts the pixels a hybrid image loses: where it is the background colour exactly and the reference (the exact
engine's image of the same camera) is not, and more generally where the two differ by more than a threshold.

Usage: bench/hybrid_lost_rays.py HYBRID.png EXACT.png [--background R,G,B] [--threshold N] [--list K]
Prints one JSON line: pixels, lost (background in HYBRID, not in EXACT), differing (max channel difference > N, 8-bit),
and the first K lost pixels as [x, y]. Standard library only (bench/side_by_side.py reads the PNGs).
"""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from side_by_side import read_png  # noqa: E402


def main(argv):
    args = [a for a in argv[1:]]
    background, threshold, listed = (82, 87, 110), 25, 20  # ParaView's default background, 8-bit
    for flag in ("--background", "--threshold", "--list"):
        if flag in args:
            i = args.index(flag)
            value = args[i + 1]
            del args[i:i + 2]
            if flag == "--background":
                background = tuple(int(v) for v in value.split(","))
            elif flag == "--threshold":
                threshold = int(value)
            else:
                listed = int(value)
    if len(args) != 2:
        sys.exit(__doc__)
    w, h, a = read_png(args[0])
    w2, h2, b = read_png(args[1])
    if (w, h) != (w2, h2):
        sys.exit(f"{args[0]} is {w}x{h}, {args[1]} {w2}x{h2}")
    lost, differing, where = 0, 0, []
    for y in range(h):
        ra, rb = a[y], b[y]
        for x in range(w):
            pa, pb = tuple(ra[3 * x:3 * x + 3]), tuple(rb[3 * x:3 * x + 3])
            if max(abs(pa[c] - pb[c]) for c in range(3)) > threshold:
                differing += 1
            if pa == background and pb != background:
                lost += 1
                if len(where) < listed:
                    where.append([x, y])
    print(json.dumps({"pixels": w * h, "lost": lost, "differing": differing, "threshold": threshold,
                      "first_lost": where}))


if __name__ == "__main__":
    main(sys.argv)
