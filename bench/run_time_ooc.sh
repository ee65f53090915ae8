#!/usr/bin/env bash
# Issue 18's store with time built out of core: a generated series of STEPS steps of N cells each, built into one
# store with time in core and out of core at --memory MEMORY, alternated ROUNDS times:
#   1. ugvr generate --cells N --time-steps STEPS -o S/w.pvd                       (skipped when S/w.pvd exists)
#   2. ugvr build S/w.pvd --time all --error 0 --fields pressure --max-depth DEPTH --json
#        in core: --memory 64GiB (the in-core build only warns past --memory; 64GiB keeps it from choosing out of core)
#        out of core: --out-of-core --memory MEMORY
# and reports per build the wall time, CPU time and peak RSS (/usr/bin/time -v), out of core the peak size of the
# scratch folder "<store>.cells" (du every second), the store's size and nodes, and whether the stores agree (node
# count). One JSON line per build to bench/results/time_ooc.jsonl.
# Usage: bench/run_time_ooc.sh [N=2000000] [STEPS=6] [SCRATCH=/tmp/ugvr-time-ooc]
#   UGVR (default build/ugvr), MEMORY (256MiB), DEPTH (6), ROUNDS (1).
#   BEFORE=BINARY: a second ugvr whose out-of-core build is timed in each round too, alternated with UGVR's (before
#     first in odd rounds, after first in even ones; the in-core build is UGVR's); "mode": "out-of-core-before".
#   IN_CORE=0: skip the in-core build (a long series out of core alone).
#   Scratch: the series (about 75 bytes a hexahedral cell a step) and, out of core, the scratch folder (its peak is
#   reported).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
n=${1:-2000000}
steps=${2:-6}
scratch=${3:-/tmp/ugvr-time-ooc}
ugvr=${UGVR:-$root/build/ugvr}
memory=${MEMORY:-256MiB}
depth=${DEPTH:-6}
rounds=${ROUNDS:-1}
before=${BEFORE:-}
in_core=${IN_CORE:-1}
out=bench/results/time_ooc.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
series="$scratch/w.pvd"

peak_rss() { awk -F': ' '/Maximum resident set size/ {printf "%.0f\n", $2 * 1024}' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' "$1"; }
cpu() { awk -F': ' '/User time/ {u = $2} /System time/ {s = $2} END {print u + s}' "$1"; }

if [ ! -f "$series" ]; then
  "$ugvr" --quiet generate --cells "$n" --time-steps "$steps" -o "$series" >/dev/null
fi
step_bytes=$(stat -c %s "$scratch/w_0000.vtu")
echo "series: $steps steps of $n cells, $step_bytes bytes a step; load: $(uptime | sed 's/.*load average: //')"
# The largest size of FOLDER while process PID runs, sampled every second.
peak_du() {
  local pid=$1 folder=$2 peak=0 now
  while kill -0 "$pid" 2>/dev/null; do
    now=$(du -sb "$folder" 2>/dev/null | cut -f1 || true)
    [ -n "$now" ] && [ "$now" -gt "$peak" ] && peak=$now
    sleep 1
  done
  echo "$peak"
}

run_build() {  # mode binary round
  local mode=$1 bin=$2 round=$3 flag="--memory 64GiB" scratch_peak=0
  [ "$mode" != in-core ] && flag="--out-of-core --memory $memory"
  local store="$scratch/$mode.ugvr"
  local load
  load=$(uptime | sed 's/.*load average: //' | cut -d, -f1)
  /usr/bin/time -v "$bin" --quiet build "$series" --time all --error 0 --fields pressure --max-depth "$depth" \
    $flag --json -o "$store" >"$scratch/$mode.json" 2>"$scratch/$mode.time" &
  local pid=$!
  [ "$mode" != in-core ] && scratch_peak=$(peak_du "$pid" "$store.cells")
  wait "$pid"
  python3 - "$scratch/$mode.json" "$mode" "$round" "$(wall "$scratch/$mode.time")" \
    "$(cpu "$scratch/$mode.time")" "$(peak_rss "$scratch/$mode.time")" "$load" "$commit" "$n" "$steps" "$memory" \
    "$scratch_peak" <<'PY' | tee -a "$out"
import json, sys
j = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
mode, rnd, wall, cpu, rss, load, commit, n, steps, memory, scratch_peak = sys.argv[2:]
print(json.dumps({"bench": "time_ooc", "commit": commit, "mode": mode, "round": int(rnd), "cells": int(n),
                  "steps": int(steps), "memory": memory, "wall_s": float(wall), "cpu_s": float(cpu),
                  "peak_rss_bytes": int(rss), "load": float(load), "nodes": j["nodes"],
                  "store_bytes": j["store_bytes"], "time_steps": j["time_steps"], "out_of_core": j["out_of_core"],
                  "leaves_in_pieces": j["leaves_in_pieces"], "scratch_peak_bytes": int(scratch_peak)}))
PY
}

nodes_of() { python3 -c "import json,sys; print(json.load(open('$scratch/$1.json'))['nodes'])"; }

for round in $(seq 1 "$rounds"); do
  modes=()
  [ "$in_core" = 1 ] && modes+=(in-core)
  if [ -n "$before" ] && [ $((round % 2)) = 1 ]; then modes+=(out-of-core-before out-of-core)
  elif [ -n "$before" ]; then modes+=(out-of-core out-of-core-before)
  else modes+=(out-of-core); fi
  for mode in "${modes[@]}"; do
    bin=$ugvr
    [ "$mode" = out-of-core-before ] && bin=$before
    run_build "$mode" "$bin" "$round"
  done
  for mode in "${modes[@]}"; do
    [ "$mode" = "${modes[0]}" ] && continue
    [ "$(nodes_of "$mode")" = "$(nodes_of "${modes[0]}")" ] \
      && echo "round $round: $mode has the same node count as ${modes[0]}" \
      || echo "round $round: NODE COUNTS DIFFER ($mode, ${modes[0]})"
  done
done
