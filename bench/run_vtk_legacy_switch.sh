#!/usr/bin/env bash
# The exact engine's cold step switch on a series of BINARY legacy .vtk steps (issue 18 [time]): N^3 hexahedra
# (default N=100: 1M cells) and 3 steps on one mesh, written by bench/make_vtk_legacy_series.py and listed by a .pvd;
# then bench_time_switch on it (medians of --rounds 5). Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_vtk_legacy_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-vtk]
#   env: N (100), ROUNDS (5), ASCII=1 (ASCII files instead of BINARY); BEFORE=OTHER_BUILD_DIR: each run alternated with OTHER_BUILD_DIR's bench_time_switch
#   (ALTERNATIONS=2 pairs, before first) on the same files, lines tagged "build": before / after.
# Needs BUILD_DIR's bench/bench_time_switch and python3 with numpy. Disk: about 110 MB a step at N=100.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-vtk}
n=${N:-100}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
. bench/time_switch_common.sh
time_switch_session run_vtk_legacy_switch

ascii=${ASCII:-}
dir=$scratch/n$n${ascii:+-ascii}
[ -f "$dir/flow.pvd" ] || /usr/bin/python3 bench/make_vtk_legacy_series.py "$dir" --n "$n" --steps 3 ${ascii:+--ascii}

time_switch_runs "$dir/flow.pvd" --field pressure
