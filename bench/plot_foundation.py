#!/usr/bin/python3
"""Plots the newest session of bench/results/foundation.jsonl: reader load time and peak memory against VTK's reader,
and `ugvr generate` peak memory against output size (bounded-memory streaming)."""
import json
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker

src, dst = sys.argv[1], sys.argv[2]
rows = [json.loads(line) for line in open(src) if line.strip()]
start = max(i for i, r in enumerate(rows) if r["bench"] == "session")
session, rows = rows[start], rows[start + 1:]

ours = [r for r in rows if r["bench"] == "load"]
vtk = [r for r in rows if r["bench"] == "load-vtk"]
gen = [r for r in rows if r["bench"] == "generate"]
mib = 1024 * 1024

fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
labels = ["ugvr", "VTK 9.1"] if vtk else ["ugvr"]
secs = [statistics.median(r["seconds"] for r in ours)] + ([statistics.median(r["seconds"] for r in vtk)] if vtk else [])
ax[0].bar(labels, secs, color=["#3b6fb6", "#999999"][: len(labels)])
ax[0].set_ylabel("seconds (median of %d)" % len(ours))
ax[0].set_title("load 10M-tet .vtu")
peak = [statistics.median(r["peak_rss_bytes"] for r in ours) / mib] + (
    [statistics.median(r["peak_rss_bytes"] for r in vtk) / mib] if vtk else [])
ax[1].bar(labels, peak, color=["#3b6fb6", "#999999"][: len(labels)])
ax[1].axhline(ours[0]["dataset_bytes"] / mib, color="k", ls="--", lw=1, label="ugvr in-memory mesh")
ax[1].set_ylabel("peak RSS (MiB)")
ax[1].set_title("memory while loading")
ax[1].legend(loc="upper left", fontsize=8)
hexes = sorted((r for r in gen if r["kind"] == "hex"), key=lambda r: r["target_cells"])
if hexes:
    ax[2].plot([r["file_bytes"] / 2**30 for r in hexes], [r["peak_rss_bytes"] / mib for r in hexes], "o-",
               color="#3b6fb6", label="hex")
    mixed = [r for r in gen if r["kind"] == "mixed"]
    ax[2].plot([r["file_bytes"] / 2**30 for r in mixed], [r["peak_rss_bytes"] / mib for r in mixed], "s",
               color="#d9822b", label="mixed")
    ax[2].set_xscale("log")
    ax[2].xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
    ax[2].set_ylim(0, max(64, max(r["peak_rss_bytes"] / mib for r in gen) * 1.5))
    ax[2].set_xlabel("output .vtu (GiB)")
    ax[2].set_ylabel("peak RSS (MiB)")
    ax[2].set_title("ugvr generate: 1M to 100M cells")
    ax[2].legend(fontsize=8)
fig.suptitle("%s, commit %s, %s" % (session["date"], session["commit"], session["machine"]), fontsize=9)
fig.tight_layout()
fig.savefig(dst, dpi=110)
print("wrote", dst)
