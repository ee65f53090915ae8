#!/usr/bin/env bash
# Transfer-function edit: error recomputation time (render/lod/tf_error.h) on stores built at --error 0 (the largest
# this bench builds: the oxygen post, StagnationEnergy), and the cost of the error table in the store: size and build
# time with the table (this build) against a store of the same tree without it (the table's bytes, from the header).
# usage: bench/run_tf_error.sh BUILD_DIR OUT_DIR       (BUILD_DIR has ugvr and bench/bench_tf_error)
set -euo pipefail
BUILD=$1
OUT=$2
DATA=${UGVR_DATA:-$(cd "$(dirname "$0")/../.." && pwd)/shared/data}
mkdir -p "$OUT"
run() {  # name xyz q field
  local name=$1 xyz=$2 q=$3 field=$4
  if [[ ! -f $OUT/$name.ugvr ]]; then
    /usr/bin/time -f "%e s wall, %U+%S s cpu" -o "$OUT/$name.time" \
      "$BUILD/ugvr" --quiet build "$xyz" "$q" -o "$OUT/$name.ugvr" --fields "$field" --error 0 --max-depth 14 --json \
      > "$OUT/$name.json"
  fi
  echo "$name build: $(cat "$OUT/$name.time"); $(stat -c %s "$OUT/$name.ugvr") bytes"
  "$BUILD/bench/bench_tf_error" "$OUT/$name.ugvr" "$field" 21
}
run bluntfin "$DATA/blunt-fin/bluntfinxyz.bin" "$DATA/blunt-fin/bluntfinq.bin" Density
run oxygenpost "$DATA/lox-post/postxyz.bin" "$DATA/lox-post/postq.bin" StagnationEnergy
