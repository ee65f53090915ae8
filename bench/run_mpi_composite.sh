#!/usr/bin/env bash
# Sort-last compositing cost (docs/mpi.md): bench_mpi_composite (bench/mpi/) under mpirun for 2, 4 and 8 ranks at
# 1920x1080, RGBA float, for each compositor; one JSON line per run (the median over REPEAT frames of the slowest
# rank's time in the compositor) appended to bench/results/mpi_composite.jsonl after a `session` line.
# Usage: bench/run_mpi_composite.sh
#   BENCH=path/to/bench_mpi_composite (default build/bench/bench_mpi_composite), RANKS (default "2 4 8"),
#   COMPOSITORS (default "icet-radixk icet-bswap icet-tree direct-send"), SIZE (default "1920 1080"), REPEAT (11),
#   IMAGES (default "sparse dense": each rank a disc of a third of the frame's height, or every pixel partly opaque).
# Ranks beyond the cores are oversubscribed (--oversubscribe): on a 2-core machine 4 and 8 ranks share 2 cores, so
# the times include the operating system's time slicing; say so wherever they are quoted.
set -euo pipefail
cd "$(dirname "$0")/.."
bench=${BENCH:-build/bench/bench_mpi_composite}
ranks=${RANKS:-"2 4 8"}
compositors=${COMPOSITORS:-"icet-radixk icet-bswap icet-tree direct-send"}
size=${SIZE:-"1920 1080"}
repeat=${REPEAT:-11}
images=${IMAGES:-"sparse dense"}
out=bench/results/mpi_composite.jsonl
mkdir -p bench/results
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s"}\n' "$(date -u +%FT%TZ)" \
  "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" >> "$out"
for kind in $images; do
  for c in $compositors; do
    for n in $ranks; do
      UGVR_COMPOSITOR=$c mpirun --oversubscribe -np "$n" -x UGVR_COMPOSITOR "$bench" $size "$repeat" "$kind" |
        tee -a "$out"
    done
  done
done
