#!/usr/bin/env bash
# The exact engine under MPI (docs/mpi.md, "Rendering per rank"): the oxygen post (102,675 hexahedra) at 512x512,
# `--threads 1` a rank, 1, 2 and 4 ranks, FRAMES frames; one JSON line per run appended to
# bench/results/mpi_exact.jsonl after a `session` line: the median frame time after the first (rank 0's whole frame:
# render, gather and compositing), each rank's engine render time (wall and CPU) and cells entered in the last frame,
# each rank's engine bytes (its walk mesh and field) and peak resident set. With BASE=path/to/another/ugvr the same runs alternate with that binary
# (e.g. a build without the per-rank parts) so both are measured in one session; a binary without the per-rank
# figures reports only the frame time and its slowest and fastest rank.
# Usage: bench/run_mpi_exact.sh [UGVR]   (default build/ugvr); env: BASE, RANKS (default "1 2 4"), FRAMES (default 4),
#   SIZE (512), UGVR_DATA (default /work/shared/data).
# Ranks beyond the cores are oversubscribed: on a 2-core machine 4 ranks share 2 cores (time slicing included).
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=${1:-build/ugvr}
base=${BASE:-}
ranks=${RANKS:-"1 2 4"}
frames=${FRAMES:-4}
size=${SIZE:-512}
data=${UGVR_DATA:-/work/shared/data}
post="$data/lox-post/postxyz.bin $data/lox-post/postq.bin"
out=bench/results/mpi_exact.jsonl
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p bench/results
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s"}\n' "$(date -u +%FT%TZ)" \
  "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" >> "$out"
for n in $ranks; do
  for run in part whole $base; do
    bin=$ugvr whole=0
    case $run in part) ;; whole) whole=1 ;; *) bin=$run ;; esac
    # shellcheck disable=SC2086
    UGVR_MPI_WHOLE_MESH=$whole mpirun --oversubscribe -np "$n" -x UGVR_MPI_WHOLE_MESH "$bin" render $post --tf viridis \
      --engine exact --threads 1 --size "$size" \
      --frames "$frames" --stats "$tmp/s.json" -o "$tmp/img.png" 2> "$tmp/err" || { cat "$tmp/err"; exit 1; }
    python3 - "$tmp/s.json" "$bin" "$n" "$whole" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
m = s.get("mpi", {})
r = {"binary": sys.argv[2], "ranks": int(sys.argv[3]), "whole_mesh": sys.argv[4] == "1", "load": float(sys.argv[5]),
     "median_frame_seconds": round(s["median_frame_seconds"], 4),
     "render_seconds_max": round(m.get("render_seconds_max", 0), 4),
     "render_seconds_min": round(m.get("render_seconds_min", 0), 4),
     "composite_seconds": round(m.get("composite_seconds", 0), 4)}
for k in ("rank_render_seconds", "rank_render_cpu_seconds", "rank_samples", "rank_engine_bytes", "rank_peak_rss_bytes"):
    if k in m:
        r[k] = [round(v / 2**20, 1) if "bytes" in k else int(v) if k == "rank_samples" else round(v, 4) for v in m[k]]
r = {k.replace("_bytes", "_mib"): v for k, v in r.items()}
print(json.dumps(r))
PY
  done
done
