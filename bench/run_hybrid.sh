#!/usr/bin/env bash
# Hybrid rendering against the exact engine (the [hybrid] issue, part 2; docs/hybrid.md): blunt fin (Density),
# oxygen post (StagnationEnergy) and the demo (scene `demo`: scripts/demo.sh's mesh, camera and transfer function) built with their leaves' cells (`ugvr build --cells`), at SIZE² with the cameras of
# bench/results/exact-render and the steep transfer function of bench/run_lod_fidelity.sh (opacity rising from 0 to
# 0.9 over 10 % of the field's range, unit distance diagonal / 200). Per scene: the exact engine's image (CPU), the
# voxel image (`--engine lod --cut leaves`) and the converged hybrid image (`--engine hybrid`: every visible leaf with
# cells exact while --gpu-cell-memory allows), PSNR of each against the exact image (`ugvr compare`), median frame
# time over FRAMES frames (the exact engine's: one frame on the CPU, when its image is made), and the three side by
# side (bench/side_by_side.py).
# Usage: bench/run_hybrid.sh LABEL [OUT_DIR=SCRATCH/LABEL] [SCRATCH=/tmp/ugvr-hybrid]
#   UGVR (default build/ugvr), UGVR_DATA (default ../shared/data), SCENES ("blunt-fin lox-post"; also "demo"), SIZE (512),
#   FRAMES (3), PYTHON (python3), EXTRA (more flags for both LOD renders, e.g. "--gpu 0"), VIEW_EXTRA (more flags for
#   all three renders, e.g. "--mode mip" or "--iso 0.1,0.5": use another SCRATCH, which keeps the exact reference).
# One JSON line per scene is appended to bench/results/hybrid.jsonl after a `session` line.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
label=$1
scratch=${3:-/tmp/ugvr-hybrid}
outdir=${2:-$scratch/$label}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
scenes=${SCENES:-blunt-fin lox-post}
size=${SIZE:-512}
frames=${FRAMES:-3}
py=${PYTHON:-$(command -v python3)}
extra=(${EXTRA:-})
view_extra=(${VIEW_EXTRA:-})
jsonl=bench/results/hybrid.jsonl
mkdir -p "$outdir" "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"label\":\"$label\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"ugvr\":\"$ugvr\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$jsonl"

steep_tf() {
  cat >"$1" <<JSON
[{"Name": "steep", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.267, 0.005, 0.329, $2, 0.128, 0.567, 0.551, $3, 0.369, 0.789, 0.383, 1.0, 0.993, 0.906, 0.144],
  "Points": [0.0, 0.0, 0.5, 0.0, $2, 0.0, 0.5, 0.0, $3, 0.9, 0.5, 0.0, 1.0, 0.9, 0.5, 0.0]}]
JSON
}
diagonal() {
  "$ugvr" info "$@" | "$py" -c "
import re, sys, math
for line in sys.stdin:
    if line.startswith('bounds:'):
        v = [float(x) for x in re.findall(r'[-+0-9.eE]+', line)]
        print(math.sqrt((v[1]-v[0])**2 + (v[3]-v[2])**2 + (v[5]-v[4])**2)); break"
}
json_get() { "$py" -c "import json,sys; j=json.load(open('$1')); print(eval('j' + sys.argv[1]))" "$2"; }

for name in $scenes; do
  case $name in
    blunt-fin) field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") band=(0.15 0.25) ;;
    lox-post) field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") band=(0.7 0.8) ;;
    demo) field=pressure inputs=("$scratch/demo.vtu") band=() ;;
    *) echo "unknown scene $name" >&2; exit 1 ;;
  esac
  if [ $name = demo ]; then
    # The demo's first view (scripts/demo.sh, src/cli/demo_scene.h): its 200,000-cell mixed mesh, camera and
    # transfer function (its own unit distance, the range as given), over its dark background.
    [ -f "${inputs[0]}" ] || "$ugvr" --quiet generate --cells 200000 --kind mixed -o "${inputs[0]}"
    sed -n '/^cat >out\/demo-camera.json/,/^JSON/p; /^cat >out\/demo-tf.json/,/^JSON/p' scripts/demo.sh |
      sed "s#out/#$scratch/#" | bash
    view=(--camera "$scratch/demo-camera.json" --tf "$scratch/demo-tf.json" --keep-range --background 0.02,0.02,0.04
      --size "$size" --field "$field")
  else
    steep_tf "$scratch/$name-tf.json" "${band[@]}"
    unit=$("$py" -c "print($(diagonal "${inputs[@]}") / 200)")
    view=(--camera "bench/results/exact-render/$name-camera.json" --tf "$scratch/$name-tf.json" --unit-distance "$unit"
      --size "$size" --field "$field")
  fi
  view+=("${view_extra[@]}")
  store="$scratch/$name-cells.ugvr"
  [ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$field" --cells -o "$store"
  ref="$scratch/$name-exact.pfm"
  [ -f "$ref" ] && [ -f "$scratch/$name-exact-stats.json" ] ||
    "$ugvr" --quiet render "${inputs[@]}" --engine exact --device cpu "${view[@]}" \
      -o "$scratch/$name-exact.png" --float "$ref" --stats "$scratch/$name-exact-stats.json"
  cp "$scratch/$name-exact.png" "$outdir/$name-exact.png"
  for engine in lod hybrid; do
    cut=(); [ $engine = lod ] && cut=(--cut leaves)
    "$ugvr" --quiet render "$store" --engine $engine "${cut[@]}" "${view[@]}" "${extra[@]}" --frames "$frames" \
      -o "$outdir/$name-$engine.png" --float "$scratch/$name-$engine.pfm" --stats "$scratch/$name-$engine-stats.json"
    "$ugvr" compare "$scratch/$name-$engine.pfm" "$ref" --json "$scratch/$name-$engine-cmp.json" >/dev/null
  done
  "$py" bench/side_by_side.py "$outdir/$name-exact-voxels-hybrid.png" "$outdir/$name-exact.png" "$outdir/$name-lod.png" \
    "$outdir/$name-hybrid.png" --gap 4
  line=$("$py" - "$scratch" "$name" "$label" <<'PY'
import json, sys
scratch, name, label = sys.argv[1:4]
out = {"bench": "hybrid", "label": label, "scene": name}
s = json.load(open(f"{scratch}/{name}-exact-stats.json"))
out["exact_cpu"] = {"median_frame_seconds": s["median_frame_seconds"], "threads": s.get("threads")}
for e in ("lod", "hybrid"):
    s = json.load(open(f"{scratch}/{name}-{e}-stats.json"))
    c = json.load(open(f"{scratch}/{name}-{e}-cmp.json"))
    out[e] = {"psnr_db": c["psnr_db"], "ssim": c["ssim"], "median_frame_seconds": s["median_frame_seconds"],
              "cut_nodes": s["cut_nodes"], "renderer": s.get("renderer")}
    if "hybrid" in s:
        out[e]["hybrid"] = s["hybrid"]
print(json.dumps(out))
PY
)
  echo "$line" >>"$jsonl"
  echo "$line" | "$py" -c "
import json, sys
j = json.loads(sys.stdin.read()); v, h = j['lod'], j['hybrid']; x = h.get('hybrid', {})
print('%-10s voxels %6.2f dB %7.3f s | hybrid %6.2f dB %7.3f s, %s of %s cut nodes exact, %s cells, budget full %s' % (
    j['scene'], v['psnr_db'], v['median_frame_seconds'], h['psnr_db'], h['median_frame_seconds'],
    x.get('exact_nodes'), h['cut_nodes'], x.get('exact_cells'), x.get('cell_budget_full')))"
done
