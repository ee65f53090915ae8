#!/usr/bin/env bash
# Reading only a rank's part of a .pvtu (docs/mpi.md, "Reading only a rank's part"; bench/README.md, section "[mpi]
# issue 20: each rank reads only its part of a .pvtu"): a generated tet mesh (CELLS, default 2M) written as a .pvtu
# of PIECES pieces (default 16, the boxes of a kd-tree: bench_write_pvtu), rendered with the exact engine by 1, 2 and
# 4 ranks at SIZE (default 256), `--threads 1` a rank, one frame; each run alternates this binary (AFTER) with
# BEFORE (default /work/main/build/ugvr: every rank reads the whole mesh, then keeps its part), REPEATS times (3).
# Per run: each rank's peak resident set (getrusage's ru_maxrss, i.e. VmHWM, from --stats' mpi.rank_peak_rss_bytes:
# reading and the walk-mesh build included, the frame too), each rank's cells decoded and kept (this binary only) and
# the command's wall time. One JSON line per run is appended to bench/results/mpi_part_read.jsonl after a `session`
# line, and the medians are printed.
# INPUT=FILE renders that file instead of the generated .pvtu (an Exodus file, a .vtu of several <Piece>s or a
# raw-appended single-piece .vtu, read by parts too: docs/mpi.md); the table then adds each run's read seconds (the
# largest rank's mpi.rank_read_seconds: reading, the exchanges and the part's walk mesh; before: the whole read, the
# walk mesh and keeping the part).
# Usage: bench/run_mpi_part_read.sh [AFTER] [WORK]   (default build/ugvr, /tmp/ugvr-bench-part-read);
#   env: BEFORE, CELLS, PIECES, SIZE, RANKS ("1 2 4"), REPEATS (3), INPUT. Needs build/bench/bench_write_pvtu.
# Ranks beyond the cores are oversubscribed: on a 2-core machine 4 ranks share 2 cores (time slicing included).
set -euo pipefail
cd "$(dirname "$0")/.."
after=$(realpath "${1:-build/ugvr}")
work=${2:-/tmp/ugvr-bench-part-read}
before=${BEFORE:-/work/main/build/ugvr}
cells=${CELLS:-2000000}
pieces=${PIECES:-16}
size=${SIZE:-256}
ranks=${RANKS:-"1 2 4"}
repeats=${REPEATS:-3}
writer=build/bench/bench_write_pvtu
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=bench/results/mpi_part_read.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
pvtu=$work/tet-$cells-p$pieces.pvtu
if [ -n "${INPUT:-}" ]; then
  pvtu=$(realpath "$INPUT")
else
  [ -f "$mesh" ] || "$after" --quiet generate --cells "$cells" --kind tet -o "$mesh"
  [ -f "$pvtu" ] || "$writer" "$mesh" "$pvtu" "$pieces" kd
fi
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "cells": %s, "pieces": %s, "size": %s, "input": "%s"}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$cells" \
  "$pieces" "$size" "$(basename "$pvtu")" >> "$out"
runs=$work/runs.jsonl
: > "$runs"
for repeat in $(seq "$repeats"); do
  for n in $ranks; do
    for which in before after; do
      bin=$([ "$which" = before ] && echo "$before" || echo "$after")
      start=$(date +%s.%N)
      mpirun --oversubscribe -np "$n" "$bin" --quiet render "$pvtu" --tf viridis --engine exact --threads 1 --size "$size" \
        --stats "$work/s.json" -o "$work/img-$which-$n.png" 2> "$work/err" || { cat "$work/err"; exit 1; }
      wall=$(echo "$(date +%s.%N) - $start" | bc)
      python3 - "$work/s.json" "$which" "$n" "$repeat" "$wall" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out" >> "$runs"
import json, sys
m = json.load(open(sys.argv[1]))["mpi"]
mib = lambda v: round(v / 2**20, 1)
r = {"binary": sys.argv[2], "ranks": int(sys.argv[3]), "repeat": int(sys.argv[4]), "wall_seconds": round(float(sys.argv[5]), 2),
     "load": float(sys.argv[6]), "rank_peak_rss_mib": [mib(v) for v in m["rank_peak_rss_bytes"]],
     "read": m.get("read", "whole (before)")}
for k in ("rank_cells_read", "rank_cells_kept"):
    if k in m:
        r[k] = [int(v) for v in m[k]]
if "rank_read_seconds" in m:
    r["rank_read_seconds"] = [round(v, 2) for v in m["rank_read_seconds"]]
print(json.dumps(r))
PY
    done
  done
done
python3 - "$runs" <<'PY'
import json, statistics, sys
runs = [json.loads(l) for l in open(sys.argv[1])]
print("ranks | binary | peak RSS per rank, max (MiB, median) | mean over ranks | cells decoded / kept per rank (max) | read s, largest rank (median) | wall s | read")
for n in sorted({r["ranks"] for r in runs}):
    row = {}
    for b in ("before", "after"):
        rs = [r for r in runs if r["ranks"] == n and r["binary"] == b]
        peak = statistics.median(max(r["rank_peak_rss_mib"]) for r in rs)
        mean = statistics.median(sum(r["rank_peak_rss_mib"]) / n for r in rs)
        cells = f'{max(rs[0]["rank_cells_read"])} / {max(rs[0]["rank_cells_kept"])}' if "rank_cells_read" in rs[0] else "-"
        row[b] = peak
        read_s = statistics.median(max(r["rank_read_seconds"]) for r in rs) if "rank_read_seconds" in rs[0] else float("nan")
        print(f'{n} | {b} | {peak:.1f} | {mean:.1f} | {cells} | {read_s:.3f} | {statistics.median(r["wall_seconds"] for r in rs):.2f} | {rs[0]["read"]}')
    print(f'{n} | after/before | {row["after"] / row["before"]:.2f}')
PY
