#!/usr/bin/env bash
# The exact engine's time-step switch against loading the mesh again (issue 18 [time]): bench_time_switch on mug.e
# (Exodus, 21 steps, static by format) and on generated .pvd series (static detected by fingerprint), medians of
# --rounds switches. Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_time_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-time] [CELLS="200000 2000000"]
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-time}
cells=${3:-200000 2000000}
data=${UGVR_DATA:-../shared/data}
out=bench/results/time_switch.jsonl
mkdir -p "$scratch" bench/results
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$out"
if [ -f "$data/exodus-misc/mug.e" ]; then
  "$build/bench/bench_time_switch" "$data/exodus-misc/mug.e" --field convected --rounds 11 | tee -a "$out"
fi
for n in $cells; do
  "$build/ugvr" --quiet generate -o "$scratch/wake-$n.pvd" --cells "$n" --time-steps 3 >/dev/null
  "$build/bench/bench_time_switch" "$scratch/wake-$n.pvd" --field pressure --rounds 5 | tee -a "$out"
  rm -f "$scratch/wake-$n"*
done
