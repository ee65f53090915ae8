#!/usr/bin/env bash
# Leaf resolution study (issue 25, part 3): a coarse curvilinear PLOT3D grid (57 x 33 x 25 points of nearly uniform
# cells, bench/make_coarse_plot3d.py synthetic) built at --error 0, its leaves rendered (lod, --cut leaves, llvmpipe) against the exact
# engine with the same camera and transfer function; then blunt fin and oxygen post at --error 0 (depth, store size,
# build time). Writes OUT/leaf-resolution.txt.
# usage: bench/run_leaf_resolution.sh UGVR_BINARY OUT_DIR [coarse|real|all]
set -euo pipefail
UGVR=$1
OUT=$2
WHAT=${3:-all}
DATA=${UGVR_DATA:-$(cd "$(dirname "$0")/../.." && pwd)/shared/data}
mkdir -p "$OUT"
LOG=$OUT/leaf-resolution.txt
HERE=$(cd "$(dirname "$0")" && pwd)
build() {  # name xyz q field
  local name=$1 xyz=$2 q=$3 field=$4
  /usr/bin/time -f "%e s wall, %U+%S s cpu, %M KiB peak" -o "$OUT/$name.time" \
    "$UGVR" --quiet build "$xyz" "$q" -o "$OUT/$name.ugvr" --fields "$field" --error 0 --max-depth 14 --json \
    > "$OUT/$name.json"
  echo "$name: $(cat "$OUT/$name.time"); $(stat -c %s "$OUT/$name.ugvr") bytes; $(python3 -c "import json,sys; j=json.load(open('$OUT/$name.json')); print('nodes', j['nodes'], 'leaves', j['leaves'], 'depth mean/max', round(j['depth_avg'], 2), j['depth_max'])")" | tee -a "$LOG"
}
if [[ $WHAT == coarse || $WHAT == all ]]; then
  python3 "$HERE/make_coarse_plot3d.py" synthetic "$OUT/coarse" 
  build coarse "$OUT/coarse/coarsexyz.bin" "$OUT/coarse/coarseq.bin" Density
  "$UGVR" --quiet render "$OUT/coarse/coarsexyz.bin" "$OUT/coarse/coarseq.bin" --field Density --view iso \
    -o "$OUT/coarse-exact.png" --save-camera "$OUT/coarse-camera.json" --save-tf "$OUT/coarse-tf.json"
  "$UGVR" --quiet render "$OUT/coarse.ugvr" --field Density --camera "$OUT/coarse-camera.json" \
    --tf "$OUT/coarse-tf.json" --keep-range --cut leaves -o "$OUT/coarse-leaves.png"
  echo "coarse leaves vs exact: $("$UGVR" compare "$OUT/coarse-leaves.png" "$OUT/coarse-exact.png" 2>&1 | tr '\n' ' ')" | tee -a "$LOG"
fi
if [[ $WHAT == real || $WHAT == all ]]; then
  build bluntfin "$DATA/blunt-fin/bluntfinxyz.bin" "$DATA/blunt-fin/bluntfinq.bin" Density
  build oxygenpost "$DATA/lox-post/postxyz.bin" "$DATA/lox-post/postq.bin" StagnationEnergy
fi
