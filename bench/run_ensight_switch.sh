#!/usr/bin/env bash
# The exact engine's cold step switch on an EnSight Gold case with one geometry (issue 18 [time]): N^3 hexahedra
# (default N=100: 1M cells), C binary, 3 steps of a per-node and a per-element scalar, written by
# bench/make_ensight_case.py; then bench_time_switch --read-pairs on it (medians of --rounds 5), as
# bench/run_openfoam_switch.sh does for OpenFOAM. Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_ensight_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-ensight]
#   env: N (100), ROUNDS (5); BEFORE=OTHER_BUILD_DIR, ALTERNATIONS: as bench/time_switch_common.sh.
# Needs BUILD_DIR's bench/bench_time_switch and python3 with numpy. Disk: about 70 MB at N=100.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-ensight}
n=${N:-100}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
. bench/time_switch_common.sh
time_switch_session run_ensight_switch

dir=$scratch/n$n
[ -f "$dir/block.case" ] || /usr/bin/python3 bench/make_ensight_case.py "$dir" --n "$n" --steps 3

time_switch_runs "$dir/block.case" --field p --read-pairs
