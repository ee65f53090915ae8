#!/usr/bin/env bash
# Issue 18's store with time built out of core: a generated series of STEPS steps of N cells each, built into one
# store with time in core and out of core at --memory MEMORY, alternated ROUNDS times:
#   1. ugvr generate --cells N --time-steps STEPS -o S/w.pvd                       (skipped when S/w.pvd exists)
#   2. ugvr build S/w.pvd --time all --error 0 --fields pressure --max-depth DEPTH --json
#        in core: --memory 64GiB (the in-core build only warns past --memory; 64GiB keeps it from choosing out of core)
#        out of core: --out-of-core --memory MEMORY
# and reports per build the wall time, CPU time and peak RSS (/usr/bin/time -v), the store's size and nodes, and
# whether the two stores agree (node count, store size). One JSON line per build to bench/results/time_ooc.jsonl.
# Usage: bench/run_time_ooc.sh [N=2000000] [STEPS=6] [SCRATCH=/tmp/ugvr-time-ooc]
#   UGVR (default build/ugvr), MEMORY (256MiB), DEPTH (6), ROUNDS (1). Scratch: the series (about 60 bytes a hexahedral
#   cell a step) and, out of core, one step's soup and pending nodes' files (about 3 times a step's file).
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
out=bench/results/time_ooc.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
series="$scratch/w.pvd"

peak_rss() { awk -F': ' '/Maximum resident set size/ {print $2 * 1024}' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' "$1"; }
cpu() { awk -F': ' '/User time/ {u = $2} /System time/ {s = $2} END {print u + s}' "$1"; }

if [ ! -f "$series" ]; then
  "$ugvr" --quiet generate --cells "$n" --time-steps "$steps" -o "$series" >/dev/null
fi
step_bytes=$(stat -c %s "$scratch/w_0000.vtu")
echo "series: $steps steps of $n cells, $step_bytes bytes a step; load: $(uptime | sed 's/.*load average: //')"
for round in $(seq 1 "$rounds"); do
  for mode in in-core out-of-core; do
    flag="--memory 64GiB"
    [ "$mode" = out-of-core ] && flag="--out-of-core --memory $memory"
    store="$scratch/$mode.ugvr"
    load=$(uptime | sed 's/.*load average: //' | cut -d, -f1)
    /usr/bin/time -v "$ugvr" --quiet build "$series" --time all --error 0 --fields pressure --max-depth "$depth" \
      $flag --json -o "$store" >"$scratch/$mode.json" 2>"$scratch/$mode.time"
    line=$(python3 - "$scratch/$mode.json" "$mode" "$round" "$(wall "$scratch/$mode.time")" \
      "$(cpu "$scratch/$mode.time")" "$(peak_rss "$scratch/$mode.time")" "$load" "$commit" "$n" "$steps" "$memory" <<'PY'
import json, sys
j = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
mode, rnd, wall, cpu, rss, load, commit, n, steps, memory = sys.argv[2:]
print(json.dumps({"bench": "time_ooc", "commit": commit, "mode": mode, "round": int(rnd), "cells": int(n),
                  "steps": int(steps), "memory": memory, "wall_s": float(wall), "cpu_s": float(cpu),
                  "peak_rss_bytes": int(rss), "load": float(load), "nodes": j["nodes"],
                  "store_bytes": j["store_bytes"], "time_steps": j["time_steps"], "out_of_core": j["out_of_core"],
                  "leaves_in_pieces": j["leaves_in_pieces"]}))
PY
)
    echo "$line" | tee -a "$out"
  done
  cmp -s <(python3 -c "import json,sys; print(json.load(open('$scratch/in-core.json'))['nodes'])") \
         <(python3 -c "import json,sys; print(json.load(open('$scratch/out-of-core.json'))['nodes'])") \
    && echo "round $round: the same node count in and out of core" || echo "round $round: NODE COUNTS DIFFER"
done
