#!/usr/bin/env bash
# Accuracy of the exact engine and of VTK's unstructured mappers against the independent oracle (tests/oracle),
# 256 x 256, same mesh, camera and transfer function as bench/run_exact_render.sh (run that first: it writes the
# meshes into SCRATCH and the camera / transfer function files into bench/results/exact-render).
# Usage: bench/run_exact_accuracy.sh [SCRATCH=/tmp/ugvr-bench]; BUILD=build (needs bench_exact_accuracy),
#   MAPPERS (default "bunyk pt zsweep"). Appends one JSON line per image to bench/results/exact_accuracy.jsonl.
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=${1:-/tmp/ugvr-bench}
build=${BUILD:-build}
mappers=${MAPPERS-bunyk pt zsweep}
params=bench/results/exact-render
out=bench/results/exact_accuracy.jsonl
py=/usr/bin/python3
for ds in blunt-fin:Density lox-post:StagnationEnergy; do
  name=${ds%%:*} field=${ds#*:}
  dir="$scratch/accuracy-$name"
  mkdir -p "$dir"
  peers=()
  for m in $mappers; do
    xvfb-run -a $py bench/peer_vtk_render.py --mesh "$scratch/$name.vtu" --field "$field" \
      --camera "$params/$name-camera.json" --tf "$params/$name-tf.json" --size 256 --mapper "$m" --frames 1 \
      --out "$dir/vtk-$m.pfm" >/dev/null 2>&1 && peers+=("$dir/vtk-$m.pfm") || echo "accuracy: VTK $m failed on $name" >&2
  done
  "$build/bench/bench_exact_accuracy" "$scratch/$name.vtu" "$field" "$params/$name-camera.json" \
    "$params/$name-tf.json" "$dir" "${peers[@]}" |
    $py -c 'import json,sys
for line in sys.stdin:
    r = json.loads(line); r = {"bench": "exact-accuracy", "dataset": sys.argv[1], "size": 256, **r}; print(json.dumps(r))' "$name" |
    tee -a "$out"
done
