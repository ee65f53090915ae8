#!/usr/bin/env bash
# Shader variants of the GPU exact engine, alternated on one warm machine (bench/results/gpu/exact/ab-shader-variants.txt
# was made this way, on an NVIDIA H200): the same render with UGVR_SHADER_DIR pointing at each variant's shaders/
# folder (e.g. `git show COMMIT:shaders/exact_walk.comp` and its includes into a folder), float and double walks.
# Usage: bench/run_exact_gpu_ab.sh MESH FIELD SHADERS_A SHADERS_B [OUT_DIR=/tmp/ugvr-exact-ab]
#   UGVR (default build/ugvr), SIZE (1024), ROUNDS (2), FRAMES (6), CAMERA / TF (default: the oxygen post's of
#   bench/results/exact-render). The 32.9M-tet mesh of the figures: `ugvr refine postxyz.bin postq.bin --levels 2 -o M.vtu`.
# Prints one line per render: variant precision round median_frame_s gpu_s bin_s device_bytes_per_cell lost_rays.
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=$1 field=$2 a=$(realpath "$3") b=$(realpath "$4") out=${5:-/tmp/ugvr-exact-ab}
ugvr=${UGVR:-build/ugvr}
mkdir -p "$out"
for round in $(seq "${ROUNDS:-2}"); do
  for v in A B; do
    dir=$a; [ $v = B ] && dir=$b
    for prec in float double; do
      UGVR_SHADER_DIR=$dir "$ugvr" --quiet render "$mesh" --field "$field" --keep-range --device gpu \
        --camera "${CAMERA:-bench/results/exact-render/lox-post-camera.json}" \
        --tf "${TF:-bench/results/exact-render/lox-post-tf.json}" --size "${SIZE:-1024}" --frames "${FRAMES:-6}" \
        --exact-precision $prec -o "$out/$v-$prec.png" --stats "$out/$v-$prec-$round.json"
      python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(sys.argv[2], sys.argv[3], sys.argv[4], s['median_frame_seconds'], s['gpu_seconds'], s['boundary_bin_seconds'], round(s['device_bytes_per_cell'], 2), s['lost_rays'])" \
        "$out/$v-$prec-$round.json" $v $prec "$round"
    done
  done
done
