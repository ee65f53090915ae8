#!/usr/bin/env bash
# `ugvr render MESH.vtu` of a mesh over the memory budget whose one out-of-core build's scratch does not fit the
# cache's disk (bench/README.md, "[first-image] issue 24: too little scratch, pieces built by render itself"): the
# command builds the partitioned store into the cache by itself (view/scratch_pieces.h) and draws its index, against
# the two commands a user ran before (`ugvr build MESH --pieces N --out-of-core`, then `ugvr render INDEX`), and a
# second render that finds the cached index. A generated tet mesh of CELLS cells (default 2M); the free space is
# FREE bytes ($UGVR_SCRATCH_FREE_BYTES, default 100 MB: 16 pieces at 2M cells); the memory budget MEMORY (default
# 256MiB, `$UGVR_VIEW_MEMORY_BUDGET` for render, `--memory` for build). ROUNDS rounds (default 3), each: auto, manual,
# reuse, in that order. Wall seconds from `date`; the images compared with `ugvr compare`. One JSON line per run in
# bench/results/scratch_pieces.jsonl after a `session` line.
# Usage: bench/run_scratch_pieces.sh [UGVR] [WORK]   (default build/ugvr, /tmp/ugvr-bench-scratch-pieces)
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
work=${2:-/tmp/ugvr-bench-scratch-pieces}
cells=${CELLS:-2000000}
free=${FREE:-100000000}
memory=${MEMORY:-256MiB}
rounds=${ROUNDS:-3}
out=bench/results/scratch_pieces.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
view="--size 256 --field pressure --tf viridis --view iso"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "cells": %s, "free": %s, "memory": "%s"}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$cells" \
  "$free" "$memory" >> "$out"
now() { date +%s.%N; }
render_auto() {  # $1: the image
  UGVR_CACHE_DIR=$work/cache UGVR_VIEW_MEMORY_BUDGET=$memory UGVR_SCRATCH_FREE_BYTES=$free \
    "$ugvr" render "$mesh" -o "$1" $view 2> "$work/auto.log"
}
for r in $(seq "$rounds"); do
  rm -rf "$work/cache" "$work/manual.json" "$work/manual.d"
  t0=$(now); render_auto "$work/auto.png"; t1=$(now)
  pieces=$(grep -o 'building [0-9]* pieces' "$work/auto.log" | head -1 | cut -d' ' -f2)
  [ -n "$pieces" ] || { cat "$work/auto.log"; echo "render did not build pieces" >&2; exit 1; }
  printf '{"round": %s, "run": "auto", "pieces": %s, "seconds": %.2f, "load": "%s"}\n' "$r" "$pieces" \
    "$(echo "$t1 - $t0" | bc)" "$(cut -d' ' -f1 /proc/loadavg)" | tee -a "$out"
  t0=$(now)
  "$ugvr" --quiet build "$mesh" --pieces "$pieces" --out-of-core --memory "$memory" --fields pressure \
    -o "$work/manual.json" > /dev/null
  "$ugvr" --quiet render "$work/manual.json" -o "$work/manual.png" $view
  t1=$(now)
  "$ugvr" compare "$work/auto.png" "$work/manual.png" --json "$work/compare.json" > /dev/null
  # Equal images: rms 0, PSNR infinite (JSON null).
  psnr=$(python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("equal" if j["rms"] == 0 else j["psnr_db"])' \
    "$work/compare.json")
  printf '{"round": %s, "run": "manual", "pieces": %s, "seconds": %.2f, "psnr_vs_auto": "%s", "load": "%s"}\n' \
    "$r" "$pieces" "$(echo "$t1 - $t0" | bc)" "$psnr" "$(cut -d' ' -f1 /proc/loadavg)" | tee -a "$out"
  t0=$(now); render_auto "$work/again.png"; t1=$(now)
  grep -q 'partitioned store built earlier' "$work/auto.log" || { echo "the second render built again" >&2; exit 1; }
  printf '{"round": %s, "run": "reuse", "pieces": %s, "seconds": %.2f, "load": "%s"}\n' "$r" "$pieces" \
    "$(echo "$t1 - $t0" | bc)" "$(cut -d' ' -f1 /proc/loadavg)" | tee -a "$out"
done
