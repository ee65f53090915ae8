#!/usr/bin/env bash
# Foundation benchmarks (issue 2). Usage: bench/run_foundation.sh [BUILD_DIR=build] [SCRATCH=/tmp/ugvr-bench]
# Writes one JSON line per measurement to bench/results/foundation.jsonl (appending) and prints them.
#  1. .vtu load of a generated 10M-tet file: seconds, MB/s, cells/s, peak RSS / in-memory dataset (5 runs);
#     with python3-vtk9 installed, VTK's own reader on the same file in turn (peer).
#  2. Face-topology build for 10M tets: the generated file and a randomly renumbered synthetic mesh.
#  3. `ugvr generate` of 1M, 10M, 100M hexahedra and 100M mixed cells: time and peak RSS (/usr/bin/time -v); the
#     files are deleted after each run.
# Then bench/plot_foundation.py draws docs/img/bench-foundation.png from the newest session in the results.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
scratch=${2:-/tmp/ugvr-bench}
out=bench/results/foundation.jsonl
mkdir -p "$scratch" bench/results
machine="$(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1 /proc/loadavg)"
log() { echo "$1" | tee -a "$out"; }
log "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"machine\":\"$machine\"}"

tet="$scratch/tet10m.vtu"
[ -f "$tet" ] || "$build/ugvr" --quiet generate --cells 10000000 --kind tet -o "$tet" >/dev/null
for i in 1 2 3 4 5; do
  log "$("$build/bench/bench_load" "$tet" 2>/dev/null)"
  if /usr/bin/python3 -c "import vtk" 2>/dev/null; then log "$(/usr/bin/python3 bench/peer_vtk_load.py "$tet")"; fi
done

log "$("$build/bench/bench_topology" 0 "$tet")"
log "$("$build/bench/bench_topology" 10000000)"

for run in hex:1000000 hex:10000000 hex:100000000 mixed:100000000; do
  kind=${run%%:*} cells=${run#*:}
  f="$scratch/gen-$kind-$cells.vtu"
  /usr/bin/time -v "$build/ugvr" --quiet generate --cells "$cells" --kind "$kind" -o "$f" >"$scratch/gen.out" 2>"$scratch/gen.time"
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/gen.time")
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$scratch/gen.time")
  bytes=$(stat -c %s "$f")
  log "{\"bench\":\"generate\",\"kind\":\"$kind\",\"target_cells\":$cells,\"summary\":\"$(tr -d '\n' <"$scratch/gen.out")\",\"wall\":\"$wall\",\"file_bytes\":$bytes,\"peak_rss_bytes\":$((rss_kb * 1024))}"
  rm -f "$f"
done
/usr/bin/python3 bench/plot_foundation.py "$out" docs/img/bench-foundation.png || echo "(plot skipped: needs python3-matplotlib)"
