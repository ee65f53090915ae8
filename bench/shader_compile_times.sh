#!/usr/bin/env bash
# What a first frame costs beyond a steady one — mostly the GL driver compiling the compute shaders — per engine and
# shader variant: `ugvr render --frames 2 --stats`, first frame minus second, on blunt fin at 256². Made for the
# NVIDIA driver, whose compiler takes seconds on the exact walk, and which keeps compiled shaders in a disk cache
# (~/.nv/GLCache) unless `__GL_SHADER_DISK_CACHE=0`; Mesa (llvmpipe) has its own (~/.cache/mesa_shader_cache, off with
# MESA_SHADER_CACHE_DISABLE=true), and cold it takes tens of seconds on the same shaders.
# Usage: bench/shader_compile_times.sh SCRATCH [SHADER_DIR...]   (default: the repository's shaders/)
#   UGVR (default build/ugvr), UGVR_DATA, CACHE (default "off on": the driver's disk cache off, then on twice: cold
#   and warm), PYTHON. One JSON line per render on stdout.
# Each SHADER_DIR is a complete copy of shaders/ (e.g. with `#pragma optionNV(...)` lines added after #version); each
# image is compared with the first directory's (psnr_vs_first_dir; null: identical, or the first directory itself).
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=$1
shift
dirs=("$@")
[ ${#dirs[@]} -gt 0 ] || dirs=("$PWD/shaders")
ugvr=${UGVR:-$PWD/build/ugvr}
data=${UGVR_DATA:-../shared/data}
py=${PYTHON:-$(command -v python3)}
mkdir -p "$scratch"
bf=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin")
store=$scratch/bf-cells.ugvr
[ -f "$store" ] || "$ugvr" --quiet build "${bf[@]}" --fields Density --cells -o "$store" >/dev/null 2>&1
view=(--tf viridis --field Density --camera bench/results/exact-render/blunt-fin-camera.json --size 256 --frames 2)

one() {  # LABEL CACHE DIR ENGINE_ARGS...
  local label=$1 cache=$2 dir=$3
  shift 3
  local env=(UGVR_SHADER_DIR="$dir")
  [ "$cache" = off ] && env+=(__GL_SHADER_DISK_CACHE=0 MESA_SHADER_CACHE_DISABLE=true)
  local img=$scratch/$label-$(basename "$dir").pfm ref=$scratch/$label-$(basename "${dirs[0]}").pfm
  env "${env[@]}" "$ugvr" --quiet render "$@" "${view[@]}" -o "$scratch/c.png" --float "$img" \
    --stats "$scratch/c.json" 2>/dev/null ||
    { echo "{\"bench\":\"shader_compile\",\"run\":\"$label\",\"failed\":true}"; return; }
  # The image against the first shader directory's (other shaders must draw the same picture).
  local psnr=None
  [ "$img" != "$ref" ] && "$ugvr" compare "$ref" "$img" --json "$scratch/cmp.json" >/dev/null 2>&1 &&
    psnr=$("$py" -c "import json; print(json.load(open('$scratch/cmp.json'))['psnr_db'])")
  "$py" -c "
import json, sys
s = json.load(open('$scratch/c.json')); f = s['frame_seconds']
print(json.dumps({'bench': 'shader_compile', 'run': '$label', 'cache': '$cache', 'shaders': '$(basename "$dir")',
                  'first_frame_seconds': f[0], 'steady_frame_seconds': f[-1], 'first_extra_seconds': f[0] - f[-1],
                  'psnr_vs_first_dir': $psnr,
                  'renderer': s.get('renderer') or s.get('device')}))"
}

for cache in ${CACHE:-off on on}; do
  for dir in "${dirs[@]}"; do
    one exact-double "$cache" "$dir" "${bf[@]}" --engine exact --device gpu --exact-precision double
    one exact-float "$cache" "$dir" "${bf[@]}" --engine exact --device gpu --exact-precision float
    one lod "$cache" "$dir" "$store" --engine lod
    one hybrid "$cache" "$dir" "$store" --engine hybrid
  done
done
