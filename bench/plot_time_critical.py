#!/usr/bin/python3
"""Figure for bench/README.md and docs/lod-engine.md: frame time, texel error and image scale along the camera path
of bench/run_time_critical.sh, per run (target frame rate, no target, out of core).
Usage: bench/plot_time_critical.py [DIR=bench/results/time-critical] [OUT=docs/img/time-critical.png] [FPS=10]"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

folder = sys.argv[1] if len(sys.argv) > 1 else "bench/results/time-critical"
out = sys.argv[2] if len(sys.argv) > 2 else "docs/img/time-critical.png"
fps = float(sys.argv[3]) if len(sys.argv) > 3 else 10.0
runs = [
    (f"lox-post-fps{fps:g}.jsonl", f"oxygen post, target {fps:g} fps"),
    ("lox-post-full.jsonl", "oxygen post, no target (full quality)"),
    ("lox-post-fps30.jsonl", "oxygen post, target 30 fps"),
    (f"generated-ooc-fps{fps:g}.jsonl", f"generated 2.1 GiB store, RAM 64 MiB, atlas 32 MiB, {fps:g} fps"),
]
runs = [(os.path.join(folder, f), label) for f, label in runs if os.path.exists(os.path.join(folder, f))]
fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
for path, label in runs:
    rows = [json.loads(line) for line in open(path)]
    x = [r["frame"] for r in rows]
    axes[0].plot(x, [1000 * r["seconds"] for r in rows], lw=0.9, label=label)
    axes[1].plot(x, [r["mean_texel_error"] for r in rows], lw=0.9, label=label)
    axes[2].plot(x, [r.get("scale", 1) for r in rows], lw=0.9, label=label)
    rest = next((r["frame"] for r in rows if r["resting"]), None)
if runs and rest is not None:
    for ax in axes:
        ax.axvline(rest, color="gray", ls=":", lw=0.8)
    axes[0].text(rest, 0.02, " camera stops", color="gray", va="bottom", fontsize=8,
                 transform=axes[0].get_xaxis_transform())
for f in sorted({fps, 30.0}):
    axes[0].axhline(1000 / f, color="k", lw=0.8, ls="--")
    axes[0].axhline(1.2 * 1000 / f, color="r", lw=0.8, ls=":")
axes[0].plot([], [], color="k", lw=0.8, ls="--", label="targets (100 and 33 ms)")
axes[0].plot([], [], color="r", lw=0.8, ls=":", label="1.2 x target")
axes[0].set_yscale("log")
axes[0].set_ylabel("frame time (ms)")
axes[1].set_yscale("log")
axes[1].set_ylabel("mean texel error\n(output pixels per texel)")
axes[2].set_ylabel("image scale")
axes[2].set_ylim(0, 1.05)
axes[2].set_xlabel("frame (a 360° orbit, then the camera rests)")
axes[0].legend(fontsize=7, loc="upper right")
axes[0].set_title("Time-critical LOD, 512 x 512, llvmpipe on 2 cores (bench/run_time_critical.sh)")
fig.tight_layout()
fig.savefig(out, dpi=110)
print("wrote", out)
