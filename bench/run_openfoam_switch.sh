#!/usr/bin/env bash
# The exact engine's cold step switch on an OpenFOAM case (issue 18 [time]): N^3 hexahedra (default N=100: 1M cells),
# binary, with 3 time directories on the constant mesh (p and U each), written by bench/make_openfoam_case.py --steps 3;
# then bench_time_switch --read-pairs on it (medians of --rounds 5): the switch (fields only), and the step's read whole
# (read_time_step + geometry fingerprint: what a switch did before) against fields only, alternated round by round in
# one run. Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_openfoam_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-foam]
#   env: N (100), ROUNDS (5); BEFORE=OTHER_BUILD_DIR: each run alternated with OTHER_BUILD_DIR's bench_time_switch
#   (ALTERNATIONS=2 pairs, before first; that build must know --read-pairs) on the same case.
# Needs BUILD_DIR's bench/bench_time_switch and python3 with numpy. Disk: about 180 MB at N=100.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-foam}
n=${N:-100}
rounds=${ROUNDS:-5}
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
. bench/time_switch_common.sh
time_switch_session run_openfoam_switch

dir=$scratch/n$n
[ -d "$dir/constant" ] || /usr/bin/python3 bench/make_openfoam_case.py "$dir" --n "$n" --binary --steps 3

time_switch_runs "$dir" --field p --read-pairs
