#!/usr/bin/python3
"""Figure for bench/README.md and docs/viewer.md: the viewer server's RSS over a soak run of bench/run_view_soak.sh
(4 dragging and 2 reconnecting clients), with the warm-up and the +-10 % band around the median after it.
Usage: bench/plot_view_soak.py [JSONL=bench/results/view_soak.jsonl] [OUT=docs/img/view-soak.png] [RUN=latest]
                               [WARMUP_S=the run's]
Prints the RSS after the warm-up: min, median, max (MiB) and max/min."""
import json
import statistics
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

path = sys.argv[1] if len(sys.argv) > 1 else "bench/results/view_soak.jsonl"
out = sys.argv[2] if len(sys.argv) > 2 else "docs/img/view-soak.png"
rows = [json.loads(line) for line in open(path) if line.strip()]
summaries = [r for r in rows if r.get("summary")]
run = sys.argv[3] if len(sys.argv) > 3 else summaries[-1]["run"]
summary = next(r for r in summaries if r["run"] == run)
samples = [r for r in rows if r["run"] == run and not r.get("summary")]
t = [r["t"] / 60 for r in samples]
rss = [r["rss_kb"] / 1024 for r in samples]
fig, ax = plt.subplots(figsize=(9, 3.6))
ax.plot(t, rss, lw=1.2, label="server RSS")
warmup_s = float(sys.argv[4]) if len(sys.argv) > 4 else summary["warmup_s"]
warm = warmup_s / 60
after = [r["rss_kb"] / 1024 for r in samples if r["t"] >= warmup_s]
median = statistics.median(after)
print(f"after {warmup_s:g} s: min {min(after):.1f} MiB, median {median:.1f}, max {max(after):.1f}, "
      f"max/min {max(after) / min(after):.3f}")
ax.axvspan(0, warm, color="0.9", label="warm-up")
ax.axhspan(0.9 * median, 1.1 * median, color="tab:green", alpha=0.15, label="median after warm-up ±10 %")
ax.axhline(summary["rss_after_clients_kb"] / 1024, color="tab:red", ls=":", lw=1,
           label="after every client left")
c = summary["clients"]
ax.set_title(f"ugvr view soak: {summary['draggers']} dragging + {summary['cyclers']} reconnecting clients, "
             f"{summary['size']}², {c['frames']} frames, {c['connections']} connections", fontsize=9)
ax.set_xlabel("minutes")
ax.set_ylabel("MiB")
ax.set_ylim(0, max(rss) * 1.25)
ax.legend(fontsize=8, loc="lower right")
fig.tight_layout()
fig.savefig(out, dpi=110)
print(out)
