#!/usr/bin/env bash
# The exact engine's time-step switch against loading the mesh again (issue 18 [time]): bench_time_switch on mug.e
# (Exodus, 21 steps, static by format) and on generated .pvd series (static detected by stored geometry keys, else
# fingerprint), medians of --rounds switches. Appends JSON lines to bench/results/time_switch.jsonl.
# Usage: bench/run_time_switch.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench-time] [CELLS="200000 2000000"]
# BEFORE=OTHER_BUILD_DIR: every input is also run with OTHER_BUILD_DIR's bench_time_switch, alternated with BUILD_DIR's
# (ALTERNATIONS=2 pairs, before first) on the same files; each JSON line then carries "build": "before" / "after".
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench-time}
cells=${3:-200000 2000000}
data=${UGVR_DATA:-../shared/data}
out=bench/results/time_switch.jsonl
before=${BEFORE:-}
alternations=${ALTERNATIONS:-2}
mkdir -p "$scratch" bench/results
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$out"
# One input through bench_time_switch: once with BUILD_DIR, or alternated with BEFORE's.
bench() {
  if [ -z "$before" ]; then
    "$build/bench/bench_time_switch" "$@" | tee -a "$out"
    return
  fi
  for _ in $(seq "$alternations"); do
    for which in before after; do
      dir=$build
      [ "$which" = before ] && dir=$before
      "$dir/bench/bench_time_switch" "$@" | sed "s/^{/{\"build\":\"$which\",\"load\":$(cut -d' ' -f1 /proc/loadavg),/" |
        tee -a "$out"
    done
  done
}
if [ -f "$data/exodus-misc/mug.e" ]; then
  bench "$data/exodus-misc/mug.e" --field convected --rounds 11
fi
for n in $cells; do
  "$build/ugvr" --quiet generate -o "$scratch/wake-$n.pvd" --cells "$n" --time-steps 3 >/dev/null
  bench "$scratch/wake-$n.pvd" --field pressure --rounds 5
  rm -f "$scratch/wake-$n"*
done
