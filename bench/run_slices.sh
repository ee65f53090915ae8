#!/usr/bin/env bash
# Cutting planes (docs/slices.md): the LOD engine's slice against the exact engine's on blunt fin (Density) and oxygen
# post (StagnationEnergy) at SIZE² (default 512), bench/results/exact-render's cameras, the default transfer function
# (viridis over the field's range), one oblique plane through the flow each, at the default cut (pixels:1):
#  - the slice alone (--hide-volume all): PSNR, SSIM and the border metric along the lines where the plane crosses
#    faces between levels (bench_lod_seams --plane: mean error there / elsewhere on the slice, about 1: no seam);
#  - the same at a coarser cut (pixels:2: other level changes across the plane, each a bigger step);
#  - the slice with the volume (default hide none): PSNR of the whole image;
#  - LOD frame time with and without the slice (median of FRAMES frames after the first, --frames).
# Usage: bench/run_slices.sh [OUT_DIR=/tmp/ugvr-slices]
#   UGVR (default build/ugvr), SEAMS (default build/bench/bench_lod_seams), UGVR_DATA (default ../shared/data),
#   SIZE (512), FRAMES (5), PYTHON (python3). One JSON line per scene is appended to bench/results/slices.jsonl.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/ugvr-slices}
ugvr=${UGVR:-$PWD/build/ugvr}
seams=${SEAMS:-$PWD/build/bench/bench_lod_seams}
data=${UGVR_DATA:-../shared/data}
size=${SIZE:-512}
frames=${FRAMES:-5}
py=${PYTHON:-$(command -v python3)}
jsonl=bench/results/slices.jsonl
mkdir -p "$out"
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$jsonl"

# A point at fractions (fx, fy, fz) of the dataset's bounds, from `ugvr info`'s "bounds:" line, and a normal:
# "PX,PY,PZ,NX,NY,NZ".
plane_in() {
  local fx=$1 fy=$2 fz=$3 normal=$4
  shift 4
  "$ugvr" info "$@" | "$py" -c "
import re, sys
for line in sys.stdin:
    if line.startswith('bounds:'):
        v = [float(x) for x in re.findall(r'[-+0-9.eE]+', line)]
        p = [v[0] + $fx * (v[1] - v[0]), v[2] + $fy * (v[3] - v[2]), v[4] + $fz * (v[5] - v[4])]
        print(','.join('%.6g' % x for x in p) + ',$normal'); break"
}

median() { "$py" -c "import json; print(json.load(open('$1'))['median_frame_seconds'])"; }

for name in blunt-fin lox-post; do
  if [ $name = blunt-fin ]; then
    field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin")
    plane=$(plane_in 0.5 0.5 0.4 "0.2,0.3,1" "${inputs[@]}")
  else
    field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin")
    plane=$(plane_in 0.5 0.5 0.4 "0.1,0.2,1" "${inputs[@]}")
  fi
  store="$out/$name.ugvr"
  [ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$field" -o "$store"
  view=(--tf viridis --camera "bench/results/exact-render/$name-camera.json" --size "$size" --field "$field")
  for part in alone coarse volume; do
    hide=() cut=pixels:1
    [ $part != volume ] && hide=(--hide-volume all)
    [ $part = coarse ] && cut=pixels:2
    "$ugvr" --quiet render "${inputs[@]}" --engine exact --device cpu "${view[@]}" --slice "$plane" "${hide[@]}" \
      -o "$out/$name-$part-exact.png" --float "$out/$name-$part-exact.pfm"
    "$ugvr" --quiet render "$store" --engine lod --cut $cut "${view[@]}" --slice "$plane" "${hide[@]}" \
      -o "$out/$name-$part-lod.png" --float "$out/$name-$part-lod.pfm" --save-camera "$out/cam.json" \
      --save-tf "$out/tf.json" --stats "$out/$name-$part-stats.json" --frames "$frames"
    "$seams" --plane "$plane" "$store" "$field" "$out/cam.json" "$out/tf.json" $cut "$out/$name-$part-exact.pfm" \
      "$out/$name-$part-lod.pfm" "$out/$name-$part-mask.png" >"$out/$name-$part.json"
  done
  "$ugvr" --quiet render "$store" --engine lod "${view[@]}" -o "$out/$name-noslice-lod.png" \
    --stats "$out/$name-noslice-stats.json" --frames "$frames"
  echo "{\"bench\":\"slices\",\"scene\":\"$name\",\"size\":$size,\"plane\":\"$plane\",\"slice_alone\":$(cat "$out/$name-alone.json"),\"slice_alone_pixels2\":$(cat "$out/$name-coarse.json"),\"with_volume\":$(cat "$out/$name-volume.json"),\"lod_seconds_slice\":$(median "$out/$name-volume-stats.json"),\"lod_seconds_no_slice\":$(median "$out/$name-noslice-stats.json")}" |
    tee -a "$jsonl" | "$py" -c "
import json, sys
j = json.loads(sys.stdin.read()); a = j['slice_alone']; c = j['slice_alone_pixels2']; v = j['with_volume']
print('%-9s slice alone: PSNR %6.2f dB SSIM %.4f border ratio %.3f (%d border px, %d faces, %d nodes); at pixels:2 %6.2f dB, ratio %.3f (%d px); with volume: PSNR %6.2f dB; LOD frame %.3f s with the slice, %.3f s without' % (
    j['scene'], a['psnr_db'], a['ssim'], a['seam_ratio'], a['border_pixels'], a['seam_faces'], a['cut_nodes'], c['psnr_db'], c['seam_ratio'], c['border_pixels'], v['psnr_db'], j['lod_seconds_slice'], j['lod_seconds_no_slice']))"
done
