#!/usr/bin/env bash
# `ugvr refine` of the oxygen post (5-tet split, 513,375 tets) by 2 and 3 levels: cells/s, output size and peak RSS
# (/usr/bin/time -v). Usage: bench/run_refine.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench] — needs ~10 GB free.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench}
data=${UGVR_DATA:-../shared/data}
out=bench/results/refine.jsonl
mkdir -p "$scratch" bench/results
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$out"
for levels in 2 3; do
  f="$scratch/lox-$levels.vtu"
  /usr/bin/time -v "$build/ugvr" --quiet refine "$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin" -o "$f" \
    --levels "$levels" >"$scratch/refine.out" 2>"$scratch/refine.time"
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/refine.time")
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$scratch/refine.time")
  echo "{\"bench\":\"refine\",\"input\":\"lox-post\",\"levels\":$levels,\"summary\":\"$(tr -d '\n' <"$scratch/refine.out")\",\"wall\":\"$wall\",\"file_bytes\":$(stat -c %s "$f"),\"peak_rss_bytes\":$((rss_kb * 1024))}" | tee -a "$out"
  rm -f "$f"
done
