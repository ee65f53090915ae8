#!/usr/bin/env bash
# Out-of-core stores of one mesh at two memory budgets (bench/README.md, "[first-image] issue 24: out-of-core stores
# at two budgets"): `ugvr build MESH --out-of-core` and `--pieces 4 --out-of-core`, each at --memory BIG (default
# 1GiB) and SMALL (default 100KiB: 64 KiB of records per worker, so the larger leaves are sampled in pieces, and too
# little for the boundary's triangles), compared node by node (bench/compare_stores.py: tree, bricks, errors,
# transfer-function entries, boundary section) and as images (`ugvr render` 256², pressure, viridis, the iso view;
# `ugvr compare`). A generated tet mesh of CELLS cells (default 50000), --max-depth DEPTH (default 4: leaves large
# enough to be sampled in pieces at SMALL). ROUNDS rounds (default 3) of the SMALL whole build's wall seconds, for
# each binary given, alternating (the cost of measuring a leaf in pieces). One JSON line per result in
# bench/results/ooc_budgets.jsonl after a `session` line.
# Usage: bench/run_ooc_budgets.sh UGVR [UGVR_BEFORE] [WORK]   (WORK default /tmp/ugvr-bench-ooc-budgets)
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
before=${2:-}
[ -n "$before" ] && before=$(realpath "$before")
work=${3:-/tmp/ugvr-bench-ooc-budgets}
cells=${CELLS:-50000}
depth=${DEPTH:-4}
big=${BIG:-1GiB}
small=${SMALL:-100KiB}
rounds=${ROUNDS:-3}
out=bench/results/ooc_budgets.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
view="--size 256 --field pressure --tf viridis --view iso"
build="--fields pressure --max-depth $depth"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"
# "commit": this checkout's; "ugvr": the binary the structure and images come from.
printf '{"session": "%s", "commit": "%s", "ugvr": "%s", "nproc": %s, "load": "%s", "cells": %s, "depth": %s, "big": "%s", "small": "%s"}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$ugvr" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$cells" \
  "$depth" "$big" "$small" >> "$out"
psnr() {  # $1 $2: images; "equal" or the PSNR in dB
  "$ugvr" compare "$1" "$2" --json "$work/compare.json" > /dev/null
  python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("equal" if j["rms"] == 0 else round(j["psnr_db"], 2))' \
    "$work/compare.json"
}
# Structure and images, with UGVR: the whole store, then each piece.
for m in "$big" "$small"; do
  "$ugvr" --quiet build "$mesh" --out-of-core --memory "$m" $build -o "$work/whole-$m.ugvr" 2> "$work/whole-$m.log"
  "$ugvr" --quiet render "$work/whole-$m.ugvr" -o "$work/whole-$m.png" $view
  rm -rf "$work/pieces-$m.json" "$work/pieces-$m.d"
  "$ugvr" --quiet build "$mesh" --pieces 4 --out-of-core --memory "$m" $build -o "$work/pieces-$m.json" \
    > /dev/null 2> "$work/pieces-$m.log"
  "$ugvr" --quiet render "$work/pieces-$m.json" -o "$work/pieces-$m.png" $view
done
structure() {  # $1: what, $2 $3: the stores
  local json
  json=$(python3 bench/compare_stores.py "$2" "$3" || true)
  printf '{"run": "%s", "compare": %s}\n' "$1" "$json" | tee -a "$out"
}
structure whole "$work/whole-$big.ugvr" "$work/whole-$small.ugvr"
for k in 0 1 2 3; do
  structure "piece $k" "$work/pieces-$big.d/piece-$k.ugvr" "$work/pieces-$small.d/piece-$k.ugvr"
done
printf '{"run": "images", "whole_psnr": "%s", "pieces_psnr": "%s", "small_budget_warnings": %s}\n' \
  "$(psnr "$work/whole-$big.png" "$work/whole-$small.png")" "$(psnr "$work/pieces-$big.png" "$work/pieces-$small.png")" \
  "$(cat "$work/whole-$small.log" "$work/pieces-$small.log" | grep -c 'over half of the memory budget' || true)" | tee -a "$out"
# The small budget's whole build, timed, alternating the binaries.
now() { date +%s.%N; }
for r in $(seq "$rounds"); do
  for bin in "$ugvr" $before; do
    t0=$(now)
    "$bin" --quiet build "$mesh" --out-of-core --memory "$small" $build -o "$work/timed.ugvr" --json > "$work/timed.json" 2> /dev/null
    t1=$(now)
    printf '{"round": %s, "run": "small whole build", "binary": "%s", "seconds": %.2f, "leaves_in_pieces": %s, "load": "%s"}\n' \
      "$r" "$bin" "$(echo "$t1 - $t0" | bc)" \
      "$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["leaves_in_pieces"])' "$work/timed.json")" \
      "$(cut -d' ' -f1 /proc/loadavg)" | tee -a "$out"
  done
done
