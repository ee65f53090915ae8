#!/usr/bin/env bash
# The exact engine's cold step switch on a PLOT3D series (issue 18 [time]): one grid of N^3 points (default N=100: 1M
# points, 2 blocks, big-endian float32 C binary) and 3 solution files, written by bench/make_plot3d_series.py; then
# bench_time_switch --read-pairs on it (medians of --rounds 5), as bench/run_openfoam_switch.sh does for OpenFOAM.
# Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_plot3d_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-plot3d]
#   env: N (100), ROUNDS (5); BEFORE=OTHER_BUILD_DIR, ALTERNATIONS: as bench/time_switch_common.sh.
# Needs BUILD_DIR's bench/bench_time_switch and python3 with numpy. Disk: about 72 MB at N=100.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-plot3d}
n=${N:-100}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
. bench/time_switch_common.sh
time_switch_session run_plot3d_switch

dir=$scratch/n$n
[ -f "$dir/sol_0002.q" ] || /usr/bin/python3 bench/make_plot3d_series.py "$dir" --n "$n" --steps 3

time_switch_runs "$dir/grid.xyz" "$dir/sol_%04d.q" --field Density --read-pairs
