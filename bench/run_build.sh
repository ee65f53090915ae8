#!/usr/bin/env bash
# `ugvr build` of the blunt fin and the oxygen post at --error 0 (the paper's Figure 13: 22,208 and 65,324 nodes,
# 3,002 and 8,830 MB) and at the default --error 0.01: wall and CPU time, peak RSS (/usr/bin/time -v), nodes, depth,
# store size and sampling throughput, one JSON line per run appended to bench/results/build.jsonl.
# Usage: bench/run_build.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench] — needs ~1 GB free.
# UGVR_BENCH_GENERATED=N also builds a generated N-tetrahedron mesh (`ugvr generate --kind tet`, pressure, --error
# 0.01) out of core with --memory ${UGVR_BENCH_MEMORY:-1GiB}, and in core too when N <= 20M, to see how memory scales
# with the input (100M needs ~20 GB of scratch); UGVR_BENCH_SKIP_REAL=1 skips the two real datasets.
# UGVR_COMMIT overrides the commit recorded in the session line (e.g. for a run on uncommitted changes).
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench}
data=${UGVR_DATA:-../shared/data}
depth=${UGVR_BENCH_MAX_DEPTH:-14}
out=bench/results/build.jsonl
mkdir -p "$scratch" bench/results
commit=${UGVR_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$out"

run() {  # NAME FIELD ERROR MAX_DEPTH INPUT...
  local name=$1 field=$2 error=$3 max_depth=$4
  shift 4
  local f="$scratch/$name.ugvr"
  /usr/bin/time -v "$build/ugvr" --quiet build "$@" -o "$f" --fields "$field" --error "$error" \
    --max-depth "$max_depth" --json >"$scratch/build.out" 2>"$scratch/build.time"
  local rss_kb wall user sys
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/build.time")
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$scratch/build.time")
  user=$(awk -F': ' '/User time/ {print $2}' "$scratch/build.time")
  sys=$(awk -F': ' '/System time/ {print $2}' "$scratch/build.time")
  echo "{\"bench\":\"build\",\"input\":\"$name\",\"wall\":\"$wall\",\"user_s\":$user,\"sys_s\":$sys,\"time_peak_rss_bytes\":$((rss_kb * 1024)),\"summary\":$(cat "$scratch/build.out")}" |
    tee -a "$out"
  rm -f "$f"
}

fin=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin")
lox=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin")
if [[ -z ${UGVR_BENCH_SKIP_REAL:-} ]]; then
  run blunt-fin Density 0 "$depth" "${fin[@]}"
  run blunt-fin Density 0.01 8 "${fin[@]}"
  run lox-post StagnationEnergy 0 "$depth" "${lox[@]}"
  run lox-post StagnationEnergy 0.01 8 "${lox[@]}"
fi
if [[ -n ${UGVR_BENCH_GENERATED:-} ]]; then
  gen="$scratch/tet-$UGVR_BENCH_GENERATED.vtu"
  "$build/ugvr" --quiet generate --cells "$UGVR_BENCH_GENERATED" --kind tet -o "$gen" >/dev/null
  if ((UGVR_BENCH_GENERATED <= 20000000)); then run "tet-$UGVR_BENCH_GENERATED" pressure 0.01 8 "$gen"; fi
  run "tet-$UGVR_BENCH_GENERATED-out-of-core" pressure 0.01 8 "$gen" --out-of-core --memory "${UGVR_BENCH_MEMORY:-1GiB}"
  rm -f "$gen"
fi
