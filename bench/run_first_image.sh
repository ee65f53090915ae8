#!/usr/bin/env bash
# Time to the URL and to the first image of `ugvr view` on a generated tetrahedral mesh (issue 24), and the viewer's
# peak RSS: bench/first_image.py against a fresh store each run. Appends one JSON line per run to
# bench/results/first_image.jsonl after a `session` line.
# Usage: bench/run_first_image.sh [SCRATCH=/tmp/ugvr-bench]
#   UGVR (default build/ugvr), CELLS (default 10000000; the mesh is generated once into SCRATCH), WAIT (seconds to
#   wait for the store after the first image, default 0), VIEW_FLAGS (extra `ugvr view` flags, e.g.
#   "--memory-budget 1GiB" to take the out-of-core path), CUT_PX (also time the first frame whose cut's texels are at
#   most this many pixels, e.g. 4; default 0: not timed).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
scratch=${1:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
cells=${CELLS:-10000000}
wait_s=${WAIT:-0}
jsonl=bench/results/first_image.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$jsonl"
mesh="$scratch/tet-$cells.vtu"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"
# shellcheck disable=SC2086
python3 bench/first_image.py "$ugvr" "$mesh" "$scratch/tet-$cells-first.ugvr" --wait "$wait_s" \
  --cut-px "${CUT_PX:-0}" -- ${VIEW_FLAGS:-} |
  tee -a "$jsonl"
