#!/usr/bin/env bash
# The exact engine's cold step switch on a CGNS file with FlowSolutionPointers (issue 18 [time]): one structured zone
# of N^3 points (default N=100: 1M points, 970,299 hexahedra), HDF5, 3 vertex solutions, written by
# bench/make_cgns_series (built with the benchmarks); then bench_time_switch --read-pairs on it (medians of --rounds 5),
# as bench/run_openfoam_switch.sh does for OpenFOAM. Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_cgns_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-cgns]
#   env: N (100), ROUNDS (5); BEFORE=OTHER_BUILD_DIR, ALTERNATIONS: as bench/time_switch_common.sh.
# Needs BUILD_DIR's bench/bench_time_switch and bench/make_cgns_series. Disk: about 125 MB at N=100.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-cgns}
n=${N:-100}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
. bench/time_switch_common.sh
time_switch_session run_cgns_switch

mkdir -p "$scratch"
file=$scratch/box_n$n.cgns
[ -f "$file" ] || "$build/bench/make_cgns_series" "$file" --n "$n" --steps 3

time_switch_runs "$file" --field Density --read-pairs
