#!/usr/bin/env bash
# The exact engine's cold step switch on a series of .pvtu steps (issue 18 [time]): a generated wake of CELLS cells
# (default 1M) and 3 steps, each step written as a .pvtu of PIECES pieces (default 4, the boxes of a kd-tree:
# bench_write_pvtu; the same cells in the same piece every step), listed by a .pvd; then bench_time_switch on it
# (medians of --rounds 5). Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_pvtu_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-pvtu]
#   env: CELLS, PIECES, ROUNDS (5); BEFORE=OTHER_BUILD_DIR: each run alternated with OTHER_BUILD_DIR's
#   bench_time_switch (ALTERNATIONS=2 pairs, before first) on the same files, lines tagged "build": before / after.
# Needs BUILD_DIR's ugvr, bench/bench_time_switch and bench/bench_write_pvtu. Disk: about 2.3 times the .vtu series.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-pvtu}
cells=${CELLS:-1000000}
pieces=${PIECES:-4}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
mkdir -p "$scratch"
. bench/time_switch_common.sh
time_switch_session run_pvtu_switch

# The series: 3 .vtu steps generated on one mesh, each rewritten as a .pvtu of pieces, the .vtu removed.
pvd=$scratch/wake-$cells-p$pieces.pvd
if [ ! -f "$pvd" ]; then
  "$build/ugvr" --quiet generate -o "$scratch/wake.pvd" --cells "$cells" --time-steps 3 >/dev/null
  entries=""
  for k in 0 1 2; do
    vtu=$scratch/wake_000$k.vtu
    "$build/bench/bench_write_pvtu" "$vtu" "$scratch/step_$k.pvtu" "$pieces" kd >/dev/null
    rm -f "$vtu"
    entries+="    <DataSet timestep=\"$k\" part=\"0\" file=\"step_$k.pvtu\"/>\n"
  done
  rm -f "$scratch/wake.pvd"
  printf '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n%b  </Collection>\n</VTKFile>\n' \
    "$entries" >"$pvd"
fi

time_switch_runs "$pvd" --field pressure
