#!/usr/bin/env python3
"""Figure for bench/README.md: the exact engine's image beside the LOD engine's at each cut, per dataset, with the
last session's PSNR against the exact image and CPU seconds per frame (llvmpipe, 2 cores).
Usage: bench/plot_lod_render.py [RESULTS=bench/results/lod_render.jsonl] [IMAGES=bench/results/lod-render]
       [OUT=docs/img/lod-vs-exact.png]"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg
import matplotlib.pyplot as plt

results = sys.argv[1] if len(sys.argv) > 1 else "bench/results/lod_render.jsonl"
images = sys.argv[2] if len(sys.argv) > 2 else "bench/results/lod-render"
out = sys.argv[3] if len(sys.argv) > 3 else "docs/img/lod-vs-exact.png"

last = {}
for line in open(results):
    j = json.loads(line)
    if j.get("bench") == "session":
        last = {}
    elif j.get("bench") == "lod_render":
        last[(j["dataset"], j["cut"])] = j
datasets = sorted({d for d, _ in last})
cuts = [c for c in ["leaves", "pixels:1", "pixels:4"] if any((d, c) in last for d in datasets)]
fig, axes = plt.subplots(len(datasets), 1 + len(cuts), figsize=(3.2 * (1 + len(cuts)), 3.8 * len(datasets)))
if len(datasets) == 1:
    axes = [axes]
for row, d in zip(axes, datasets):
    row[0].imshow(mpimg.imread(f"{images}/{d}-exact.png"))
    row[0].set_title(f"{d}: exact engine (CPU)", fontsize=9)
    for ax, c in zip(row[1:], cuts):
        j = last[(d, c)]
        s = j["stats"]
        ax.imshow(mpimg.imread(f"{images}/{d}-lod-{c.replace(':', '')}.png"))
        ax.set_title(f"lod {c}: {s['cut_nodes']} bricks\n{j['vs_exact']['psnr_db']:.1f} dB, "
                     f"{s['median_frame_cpu_seconds']:.2f} CPU-s/frame", fontsize=9)
    for ax in row:
        ax.axis("off")
fig.suptitle("LOD engine (llvmpipe, 2 cores, 512x512) against the exact engine", fontsize=11)
fig.tight_layout()
fig.savefig(out, dpi=80)
print("wrote", out)
