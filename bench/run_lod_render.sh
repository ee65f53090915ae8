#!/usr/bin/env bash
# LOD engine (issue 5): frame time and accuracy against the exact engine on blunt fin and oxygen post.
# Usage: bench/run_lod_render.sh [OUT_DIR=bench/results/lod-render] [SCRATCH=/tmp/ugvr-bench]
#   UGVR=path/to/ugvr (default build/ugvr), UGVR_DATA (default ../shared/data), FRAMES (default 5), SIZE (512),
#   CUTS (default "leaves pixels:1 pixels:4"), ERROR (store --error, default 0.01), GPU (--gpu, default auto),
#   STEP (--step-voxels, default 0.5), DATASETS (default "blunt-fin lox-post").
# For each dataset: `ugvr build` (once, kept in SCRATCH) -> the exact engine's image of the PLOT3D grid with the
# camera and transfer function of bench/results/exact-render (the exact benchmark's scene) -> the LOD engine at each
# cut, FRAMES frames (median after the first; the first loads the bricks), compared with `ugvr compare`.
# One JSON line per run is appended to bench/results/lod_render.jsonl after a `session` line.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
outdir=${1:-bench/results/lod-render}
scratch=${2:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
frames=${FRAMES:-5}
size=${SIZE:-512}
cuts=${CUTS:-leaves pixels:1 pixels:4}
error=${ERROR:-0.01}
gpu=${GPU:-auto}
step=${STEP:-0.5}
datasets=${DATASETS:-blunt-fin lox-post}
scenes=bench/results/exact-render
jsonl=bench/results/lod_render.jsonl
mkdir -p "$outdir" "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\",\"lp_num_threads\":\"${LP_NUM_THREADS:-}\"}" | tee -a "$jsonl"

for name in $datasets; do
  case $name in
    blunt-fin) field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") ;;
    lox-post) field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") ;;
    *) echo "unknown dataset $name" >&2; exit 1 ;;
  esac
  store="$scratch/$name-e$error.ugvr"
  [ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$field" --error "$error" -o "$store"
  view=(--camera "$scenes/$name-camera.json" --tf "$scenes/$name-tf.json" --size "$size")
  ref="$outdir/$name-exact.pfm"
  [ -f "$ref" ] || "$ugvr" --quiet render "${inputs[@]}" --field "$field" "${view[@]}" -o "$outdir/$name-exact.png" --float "$ref"
  for cut in $cuts; do
    tag="$name-lod-${cut/:/}"
    "$ugvr" --quiet render "$store" --engine lod --cut "$cut" --gpu "$gpu" --step-voxels "$step" "${view[@]}" \
      --frames "$frames" -o "$outdir/$tag.png" --float "$outdir/$tag.pfm" --stats "$scratch/stats.json"
    "$ugvr" compare "$ref" "$outdir/$tag.pfm" --json "$scratch/cmp.json" >/dev/null
    echo "{\"bench\":\"lod_render\",\"dataset\":\"$name\",\"store_error\":$error,\"cut\":\"$cut\",\"step_voxels\":$step,\"vs_exact\":$(cat "$scratch/cmp.json"),\"stats\":$(cat "$scratch/stats.json")}" |
      "${PYTHON:-/usr/bin/python3}" -c "import json,sys; print(json.dumps(json.loads(sys.stdin.read()), separators=(',', ':')))" |
      tee -a "$jsonl" | "${PYTHON:-/usr/bin/python3}" -c "import json,sys; j=json.loads(sys.stdin.read()); s=j['stats']; c=j['vs_exact']; print('%-10s %-9s nodes %6d  frame %.3f s wall, %.3f s CPU (GPU %.3f s)  %.3g samples  PSNR %.2f dB  SSIM %.4f  %s' % (j['dataset'], j['cut'], s['cut_nodes'], s['median_frame_seconds'], s['median_frame_cpu_seconds'], s['gpu_seconds'], s['samples'], c['psnr_db'], c['ssim'], s['renderer']))"
  done
done
