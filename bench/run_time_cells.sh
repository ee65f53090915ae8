#!/usr/bin/env bash
# Exact cells for every step of a store with time (issue 18: `ugvr build SERIES --time all --cells`): on a generated
# series (`ugvr generate --time-steps S`), the store's size and build time against the same store without cells
# (`--time all`) and against one `--cells` store per step (`--time-step k`, summed over the steps); then the hybrid
# engine's step switch against a fresh open of the store (bench/bench_hybrid_time_switch.cpp).
#   1. ugvr generate -o SCRATCH/w.pvd --cells N --time-steps S                      (skipped when it exists)
#   2. ROUNDS rounds, in turn (alternated per round): --time all --cells, --time all, --time-step 0..S-1 --cells,
#      each `ugvr build ... --json` (its "seconds": the build's wall clock without the process start) and its file size
#   3. bench_hybrid_time_switch SCRATCH/cells.ugvr --field pressure --size SIZE --rounds ROUNDS
# Prints a table of the medians (seconds) and the sizes, then the switch's JSON line.
# Usage: bench/run_time_cells.sh [N=100000] [S=6] [SCRATCH=/tmp/ugvr-time-cells]
#   UGVR (default build/ugvr), BENCH (build/bench/bench_hybrid_time_switch), ROUNDS (3), SIZE (128),
#   OPTS (build options, default "--fields pressure,wall_distance --brick 16 --max-depth 5 --error 0")
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
n=${1:-100000}
steps=${2:-6}
scratch=${3:-/tmp/ugvr-time-cells}
ugvr=${UGVR:-$root/build/ugvr}
bench=${BENCH:-$root/build/bench/bench_hybrid_time_switch}
rounds=${ROUNDS:-3}
size=${SIZE:-128}
read -r -a opts <<<"${OPTS:---fields pressure,wall_distance --brick 16 --max-depth 5 --error 0}"
mkdir -p "$scratch"
series="$scratch/w.pvd"
[ -f "$series" ] || "$ugvr" generate -o "$series" --cells "$n" --time-steps "$steps" >/dev/null

seconds() { python3 -c 'import json,sys; t=sys.stdin.read(); print(json.loads(t[t.index("{"):])["seconds"])'; }
median() { python3 -c 'import statistics,sys; print("%.2f" % statistics.median(float(x) for x in sys.argv[1:]))' "$@"; }
build() {  # build NAME ARGS...: the build's seconds, to SCRATCH/NAME.times
  local name=$1
  shift
  "$ugvr" build "$series" "${opts[@]}" "$@" --json -o "$scratch/$name.ugvr" | seconds >>"$scratch/$name.times"
}

rm -f "$scratch"/*.times
for ((r = 0; r < rounds; ++r)); do
  order=(cells plain steps)
  ((r % 2)) && order=(steps plain cells)
  for what in "${order[@]}"; do
    case $what in
      cells) build cells --time all --cells ;;
      plain) build plain --time all ;;
      steps)
        total=0
        for ((k = 0; k < steps; ++k)); do
          build "step$k" --time-step "$k" --cells
          total=$(python3 -c "print($total + $(tail -1 "$scratch/step$k.times"))")
        done
        echo "$total" >>"$scratch/steps.times"
        ;;
    esac
  done
done
size_of() { stat -c %s "$1"; }
step_bytes=0
for ((k = 0; k < steps; ++k)); do step_bytes=$((step_bytes + $(size_of "$scratch/step$k.ugvr"))); done
echo "series: $n cells, $steps steps ($series); build ${opts[*]}; medians of $rounds"
printf '%-40s %14s %10s\n' "store" "bytes" "build s"
printf '%-40s %14s %10s\n' "--time all --cells" "$(size_of "$scratch/cells.ugvr")" "$(median $(cat "$scratch/cells.times"))"
printf '%-40s %14s %10s\n' "--time all" "$(size_of "$scratch/plain.ugvr")" "$(median $(cat "$scratch/plain.times"))"
printf '%-40s %14s %10s\n' "$steps x --time-step k --cells (sum)" "$step_bytes" "$(median $(cat "$scratch/steps.times"))"
"$bench" "$scratch/cells.ugvr" --field pressure --size "$size" --rounds "$rounds"
