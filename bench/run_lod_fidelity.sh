#!/usr/bin/env bash
# LOD fidelity against the exact engine (issue 25): PSNR, SSIM and the seam metric (bench_lod_seams.cpp) at 512² for
# the demo's camera and transfer function (velocity magnitude of `ugvr generate --cells 200000 --kind mixed`) and for
# blunt fin (Density) and oxygen post (StagnationEnergy) with a steep transfer function (opacity rising from 0 to 0.9
# over 10 % of the field's range, unit distance diagonal/200: 15-25 % of Density shows the fin and the shock, 70-80 %
# of StagnationEnergy the post's wake; bench/results/exact-render's cameras), blunt fin with a thin shell (opacity 0
# at 20 %, 0.9 at 20.5 %, 0 at 21 % of the Density range, unit distance 0.3: where a midpoint rule shows wood grain),
# at `--cut leaves` with 1, 0.5 and 0.25
# voxels per step (the step study) and at the default cut (pixels:1, step 0.5).
# Usage: bench/run_lod_fidelity.sh LABEL [OUT_DIR=SCRATCH/LABEL] [SCRATCH=/tmp/ugvr-fidelity]
#   UGVR (default build/ugvr), SEAMS (default build/bench/bench_lod_seams), UGVR_DATA (default ../shared/data),
#   SCENES (default "demo blunt-fin lox-post blunt-fin-thin"), STEPS (default "1 0.5 0.25"), SIZE (512), PYTHON (python3),
#   EXACT_ONLY=1: only make the stores and the exact images.
# The exact images and the stores are made once in SCRATCH (by whichever ugvr runs first: they do not depend on the
# LOD engine). One JSON line per LOD image is appended to bench/results/lod_fidelity.jsonl after a `session` line.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
label=$1
outdir=${2:-${3:-/tmp/ugvr-fidelity}/$label}
scratch=${3:-/tmp/ugvr-fidelity}
ugvr=${UGVR:-$root/build/ugvr}
seams=${SEAMS:-$root/build/bench/bench_lod_seams}
data=${UGVR_DATA:-../shared/data}
scenes=${SCENES:-demo blunt-fin lox-post blunt-fin-thin}
steps=${STEPS:-1 0.5 0.25}
size=${SIZE:-512}
py=${PYTHON:-$(command -v python3)}
jsonl=bench/results/lod_fidelity.jsonl
mkdir -p "$outdir" "$scratch"
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"label\":\"$label\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"ugvr\":\"$ugvr\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$jsonl"

# A steep transfer function over [0, 1] (rescaled to the field's range by render): viridis colours, opacity 0 up to
# $2, rising linearly to 0.9 at $3, 0.9 above.
steep_tf() {
  cat >"$1" <<JSON
[{"Name": "steep", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.267, 0.005, 0.329, $2, 0.128, 0.567, 0.551, $3, 0.369, 0.789, 0.383, 1.0, 0.993, 0.906, 0.144],
  "Points": [0.0, 0.0, 0.5, 0.0, $2, 0.0, 0.5, 0.0, $3, 0.9, 0.5, 0.0, 1.0, 0.9, 0.5, 0.0]}]
JSON
}

# The diagonal of the dataset's bounds, from `ugvr info`'s "bounds:" line ([a, b] x [c, d] x [e, f]).
diagonal() {
  "$ugvr" info "$@" | "$py" -c "
import re, sys, math
for line in sys.stdin:
    if line.startswith('bounds:'):
        v = [float(x) for x in re.findall(r'[-+0-9.eE]+', line)]
        print(math.sqrt((v[1]-v[0])**2 + (v[3]-v[2])**2 + (v[5]-v[4])**2)); break"
}

for name in $scenes; do
  case $name in
    demo)
      mesh="$scratch/demo.vtu"
      [ -f "$mesh" ] || "$ugvr" --quiet generate --cells 200000 --kind mixed -o "$mesh"
      inputs=("$mesh") field=velocity store_field=velocity:magnitude
      printf '%s\n' '{"position": [7.5, -9.0, 7.0], "focal_point": [0.5, 0.0, 0.6], "view_up": [0, 0, 1], "view_angle": 30}' >"$scratch/demo-camera.json"
      cat >"$scratch/demo-tf.json" <<'JSON'
[{"Name": "demo wake", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.98, 0.9, 0.15, 0.5, 0.9, 0.35, 0.1, 0.95, 0.35, 0.05, 0.45, 1.6, 0.05, 0.05, 0.25],
  "Points": [0.0, 0.9, 0.5, 0.0, 0.6, 0.5, 0.5, 0.0, 0.97, 0.02, 0.5, 0.0, 1.6, 0.0, 0.5, 0.0],
  "ScalarOpacityUnitDistance": 0.3}]
JSON
      view=(--camera "$scratch/demo-camera.json" --tf "$scratch/demo-tf.json" --keep-range --size "$size")
      ;;
    blunt-fin-thin)
      field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") store_field=Density
      cat >"$scratch/$name-tf.json" <<'JSON'
[{"Name": "thin shell", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.267, 0.005, 0.329, 0.2, 0.128, 0.567, 0.551, 0.21, 0.369, 0.789, 0.383, 1.0, 0.993, 0.906, 0.144],
  "Points": [0.0, 0.0, 0.5, 0.0, 0.2, 0.0, 0.5, 0.0, 0.205, 0.9, 0.5, 0.0, 0.21, 0.0, 0.5, 0.0, 1.0, 0.0, 0.5, 0.0]}]
JSON
      view=(--camera "bench/results/exact-render/blunt-fin-camera.json" --tf "$scratch/$name-tf.json"
        --unit-distance 0.3 --size "$size")
      ;;
    blunt-fin | lox-post)
      if [ $name = blunt-fin ]; then
        field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") band=(0.15 0.25)
      else
        field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") band=(0.7 0.8)
      fi
      store_field=$field
      steep_tf "$scratch/$name-steep-tf.json" "${band[@]}"
      diag=$(diagonal "${inputs[@]}")
      unit=$("$py" -c "print($diag / 200)")
      view=(--camera "bench/results/exact-render/$name-camera.json" --tf "$scratch/$name-steep-tf.json"
        --unit-distance "$unit" --size "$size")
      ;;
    *) echo "unknown scene $name" >&2; exit 1 ;;
  esac
  store="$scratch/${name%-thin}.ugvr"
  [ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$store_field" -o "$store"
  ref="$scratch/$name-exact.pfm"
  [ -f "$ref" ] || "$ugvr" --quiet render "${inputs[@]}" --engine exact --field "$field" "${view[@]}" \
    -o "$scratch/$name-exact.png" --float "$ref"
  cp "$scratch/$name-exact.png" "$outdir/$name-exact.png"
  [ "${EXACT_ONLY:-0}" = 1 ] && continue
  runs=()
  for s in $steps; do runs+=("leaves:$s"); done
  runs+=("pixels:1:0.5")
  for run in "${runs[@]}"; do
    cut=${run%:*} step=${run##*:}
    tag="$name-${cut/:/}-s$step"
    "$ugvr" --quiet render "$store" --engine lod --field "$store_field" --cut "$cut" --step-voxels "$step" "${view[@]}" \
      -o "$outdir/$tag.png" --float "$scratch/$tag.pfm" --save-camera "$scratch/cam.json" --save-tf "$scratch/tf.json" \
      --stats "$scratch/stats.json"
    m=$("$seams" "$store" "$store_field" "$scratch/cam.json" "$scratch/tf.json" "$cut" "$ref" "$scratch/$tag.pfm" \
      "$outdir/$tag-mask.png")
    echo "{\"bench\":\"lod_fidelity\",\"label\":\"$label\",\"scene\":\"$name\",\"cut\":\"$cut\",\"step_voxels\":$step,\"vs_exact\":$m,\"frame_seconds\":$("$py" -c "import json; print(json.load(open('$scratch/stats.json'))['median_frame_seconds'])")}" |
      tee -a "$jsonl" | "$py" -c "import json,sys; j=json.loads(sys.stdin.read()); v=j['vs_exact']; print('%-9s %-8s step %-4s PSNR %6.2f dB  SSIM %.4f  seam ratio %.3f (%d border px, %d faces)  nodes %d' % (j['scene'], j['cut'], j['step_voxels'], v['psnr_db'], v['ssim'], v['seam_ratio'], v['border_pixels'], v['seam_faces'], v['cut_nodes']))"
  done
done
