#!/usr/bin/env bash
# Every GPU figure of bench/README.md ("GPU") in one run, on a machine with a GPU: the LOD engine's frame time and
# accuracy against the exact engine (run_lod_render.sh, stores at --error 0.01 and 0), the exact engine on all cores,
# time-critical rendering at 30 and 60 fps and out of core (run_time_critical.sh), and the viewer's EGL path
# (view_socket_check.py: the scene's GL renderer, first frame, input-to-frame latency, a full-quality frame).
# Usage: bench/run_gpu.sh [OUT_DIR=bench/results/gpu] [SCRATCH=/tmp/ugvr-gpu]
#   UGVR (default build/ugvr), UGVR_DATA (default ../shared/data), PYTHON (default python3 on the PATH),
#   SIZE (default 1024), SKIP_BIG=1: no 32.9M-tet exact run, QUICK=1: tiny sizes and frame counts, to check the script itself on llvmpipe,
#   SECTIONS (default "lod exact exact-gpu time-critical view hybrid slices tricubic"): which parts to run, in the
#   order given, SEAMS (default build/bench/bench_lod_seams, for slices).
# exact-gpu: the exact engine on the GPU (exact_gpu_engine.h) against the CPU engine on blunt fin and the oxygen post,
# the oxygen post refined two levels (`ugvr refine --levels 2`, 32.9M tets) at SIZE, and the demo mesh at 1920x1080
# with the LOD engine's frame at 1920x1080 beside it; double and float walk arithmetic; device bytes per cell.
# hybrid: run_hybrid.sh (exact cells in the leaves, voxels elsewhere, against the exact engine) at SIZE; slices:
# run_slices.sh (cutting planes against the exact engine, frame time with and without); tricubic: run_tricubic.sh;
# lost-rays: run_hybrid_lost_rays.sh (llvmpipe loses a few hybrid rays at 30M: does a GPU?).
# Writes OUT_DIR/gpu.jsonl (a `session` line naming the GPU, then every result line of the scripts it runs), the
# images, and OUT_DIR/log.txt. It runs the same on llvmpipe, where it measures llvmpipe.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
out=$(mkdir -p "${1:-bench/results/gpu}" && cd "${1:-bench/results/gpu}" && pwd)
scratch=${2:-/tmp/ugvr-gpu}
mkdir -p "$scratch"
export UGVR=${UGVR:-$root/build/ugvr}
export UGVR_DATA=${UGVR_DATA:-$root/../shared/data}
export PYTHON=${PYTHON:-$(command -v python3)}
size=${SIZE:-1024}
quick=${QUICK:-}
exec > >(tee "$out/log.txt") 2>&1

gpu=$(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null | head -1 || true)
commit=${UGVR_COMMIT:-$(git rev-parse --short HEAD 2>/dev/null || echo unknown)}
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"gpu\":\"${gpu:-none}\",\"machine\":\"$(nproc) cores, $(free -g | awk '/Mem:/{print $2}') GiB, load $(cut -d' ' -f1 /proc/loadavg)\"}" |
  tee "$out/gpu.jsonl"

# The results of the scripts below are the lines they add to their jsonl files.
collect() {  # JSONL LINES_BEFORE
  tail -n +"$(($2 + 1))" "$1" | grep -v '"bench":"session"' >>"$out/gpu.jsonl" || true
}
lines() { [ -f "$1" ] && wc -l <"$1" || echo 0; }

if [[ -n $quick ]]; then
  lod_sizes="$size" frames=2 tc_frames=20 rest=5 moves=10 errors="0.01"
else
  lod_sizes="$size 2048" frames=10 tc_frames=300 rest=30 moves=120 errors="0.01 0"
fi

# dataset NAME: sets `field` and `inputs` (the PLOT3D grid and solution) of blunt-fin or lox-post.
dataset() {
  case $1 in
    blunt-fin) field=Density inputs=("$UGVR_DATA/blunt-fin/bluntfinxyz.bin" "$UGVR_DATA/blunt-fin/bluntfinq.bin") ;;
    lox-post) field=StagnationEnergy inputs=("$UGVR_DATA/lox-post/postxyz.bin" "$UGVR_DATA/lox-post/postq.bin") ;;
  esac
}

sections=${SECTIONS:-lod exact exact-gpu time-critical view hybrid slices tricubic}

section_lod() {
echo "== LOD engine vs exact (run_lod_render.sh)"
for e in $errors; do
  for s in $lod_sizes; do
    n=$(lines bench/results/lod_render.jsonl)
    ERROR=$e SIZE=$s FRAMES=$frames bash bench/run_lod_render.sh "$out/lod-e$e-$s" "$scratch"
    collect bench/results/lod_render.jsonl "$n"
  done
done
}

section_exact() {
echo "== exact engine, all cores ($(nproc))"
for name in blunt-fin lox-post; do
  dataset "$name"
  "$UGVR" --quiet render "${inputs[@]}" --field "$field" --camera "bench/results/exact-render/$name-camera.json" \
    --tf "bench/results/exact-render/$name-tf.json" --size "$size" --frames $((frames / 2 + 1)) \
    -o "$scratch/exact.png" --stats "$scratch/exact.json"
  "$PYTHON" -c "import json,sys; s=json.load(open('$scratch/exact.json')); print(json.dumps({'bench':'exact_render','dataset':'$name','size':$size,'threads':s.get('threads'),'median_frame_seconds':s['median_frame_seconds'],'median_frame_cpu_seconds':s.get('median_frame_cpu_seconds')}, separators=(',',':')))" |
    tee -a "$out/gpu.jsonl"
done
}

# exact_line TAG STATS_JSON [EXTRA_JSON]: one result line from a --stats file.
exact_line() {
  "$PYTHON" -c "import json,sys; s=json.load(open(sys.argv[2])); e=s.get('engine_stats', s); d={'bench':'exact_gpu','run':sys.argv[1],'median_frame_seconds':s.get('median_frame_seconds')}; d.update({k:s[k] for k in ('device','cells','device_bytes','device_bytes_per_cell','device_mesh_bytes_per_cell','gpu_seconds','boundary_bin_seconds','lost_rays','rays_hit','width','height') if k in s}); d.update(json.loads(sys.argv[3])); print(json.dumps(d, separators=(',',':')))" \
    "$1" "$2" "${3:-{\}}" | tee -a "$out/gpu.jsonl"
}

section_exact_gpu() {
echo "== exact engine on the GPU vs the CPU"
for name in blunt-fin lox-post; do
  dataset "$name"
  for run in cpu gpu-double gpu-float; do
    dev=${run%%-*} prec=${run#*-}; [ "$prec" = cpu ] && prec=double
    "$UGVR" --quiet render "${inputs[@]}" --field "$field" --camera "bench/results/exact-render/$name-camera.json" \
      --tf "bench/results/exact-render/$name-tf.json" --keep-range --size "$size" --frames $((frames + 1)) \
      --device "$dev" --exact-precision "$prec" -o "$out/exact-$name-$run.png" --float "$scratch/exact-$name-$run.pfm" \
      --stats "$scratch/exact-$run.json"
    psnr='{}'
    "$UGVR" --quiet compare "$scratch/exact-$name-cpu.pfm" "$scratch/exact-$name-$run.pfm" --json "$scratch/cmp.json" \
      >/dev/null 2>&1 && psnr=$(tr -d '\n' <"$scratch/cmp.json")
    exact_line "$name-$run" "$scratch/exact-$run.json" "{\"size\":$size,\"vs_cpu\":$psnr}"
  done
done
if [[ -z $quick && -z ${SKIP_BIG:-} ]]; then
  big="$scratch/lox-post-refined2.vtu"
  [ -s "$big" ] || /usr/bin/time -f "refine: %e s, %M KiB" "$UGVR" --quiet refine "$UGVR_DATA/lox-post/postxyz.bin" \
    "$UGVR_DATA/lox-post/postq.bin" --levels 2 -o "$big"
  for prec in double float; do
    "$UGVR" --quiet render "$big" --field StagnationEnergy --camera bench/results/exact-render/lox-post-camera.json \
      --tf bench/results/exact-render/lox-post-tf.json --keep-range --size "$size" --frames 6 --device gpu \
      --exact-precision "$prec" -o "$out/exact-lox-post-refined2-$prec.png" --stats "$scratch/big-$prec.json" || true
    [ -s "$scratch/big-$prec.json" ] && exact_line "lox-post-refined2-gpu-$prec" "$scratch/big-$prec.json" "{\"size\":$size}"
  done
fi
demo="$scratch/demo.vtu"
[ -s "$demo" ] || "$UGVR" --quiet generate --cells 200000 --kind mixed -o "$demo"
"$UGVR" --quiet build "$demo" -o "$scratch/demo.ugvr" --field velocity >/dev/null 2>&1 || "$UGVR" --quiet build "$demo" -o "$scratch/demo.ugvr"
dsize=1920x1080; [[ -n $quick ]] && dsize=320x180
for run in exact-cpu exact-gpu lod; do
  case $run in
    exact-cpu) args=(--engine exact --device cpu "$demo") ;;
    exact-gpu) args=(--engine exact --device gpu "$demo") ;;
    lod) args=("$scratch/demo.ugvr") ;;
  esac
  "$UGVR" --quiet render "${args[@]}" --view iso --size "$dsize" --frames $((frames / 2 + 2)) -o "$out/demo-$run.png" \
    --stats "$scratch/demo-$run.json" || continue
  exact_line "demo-$run" "$scratch/demo-$run.json" "{\"size\":\"$dsize\"}"
done
}

section_time_critical() {
echo "== time-critical (run_time_critical.sh)"
n=$(lines bench/results/time_critical.jsonl)
if [[ -n $quick ]]; then
  SIZE=$size FPS=30 FAST_FPS=60 FRAMES=$tc_frames REST=$rest bash bench/run_time_critical.sh "$out/time-critical" "$scratch"
else
  SIZE=$size FPS=30 FAST_FPS=60 FRAMES=$tc_frames REST=$rest OOC=1 bash bench/run_time_critical.sh \
    "$out/time-critical" "$scratch"
fi
collect bench/results/time_critical.jsonl "$n"
}

section_view() {
echo "== viewer over its socket (view_socket_check.py)"
dataset lox-post  # the lod section's store, or the same one built here
[ -f "$scratch/lox-post-e0.01.ugvr" ] || "$UGVR" --quiet build "${inputs[@]}" --fields "$field" --error 0.01 \
  -o "$scratch/lox-post-e0.01.ugvr"
"$PYTHON" bench/view_socket_check.py "$UGVR" "$scratch/lox-post-e0.01.ugvr" "$out/view" --size "${size}x768" \
  --moves "$moves" --fps 30 | tee -a "$out/gpu.jsonl"
}

section_hybrid() {
echo "== hybrid vs voxels vs exact (run_hybrid.sh)"
n=$(lines bench/results/hybrid.jsonl)
SIZE=$size FRAMES=$((frames / 2 + 2)) bash bench/run_hybrid.sh gpu "$out/hybrid" "$scratch/hybrid"
collect bench/results/hybrid.jsonl "$n"
}

section_slices() {
echo "== cutting planes (run_slices.sh)"
n=$(lines bench/results/slices.jsonl)
SIZE=$size FRAMES=$((frames / 2 + 2)) bash bench/run_slices.sh "$scratch/slices"
cp "$scratch"/slices/*-volume-lod.png "$out/" 2>/dev/null || true
collect bench/results/slices.jsonl "$n"
}

section_tricubic() {
echo "== tricubic isosurfaces (run_tricubic.sh)"
n=$(lines bench/results/tricubic.jsonl)
SIZE=$size FRAMES=$((frames / 2 + 2)) bash bench/run_tricubic.sh "$scratch/tricubic"
collect bench/results/tricubic.jsonl "$n"
}

section_lost_rays() {
echo "== hybrid rays lost against the exact engine, 30M tetrahedra (run_hybrid_lost_rays.sh)"
n=$(lines bench/results/hybrid_lost_rays.jsonl)
SIZE=$size bash bench/run_hybrid_lost_rays.sh "${LOST_RAYS_CELLS:-30000000}" "$scratch/lost-rays"
collect bench/results/hybrid_lost_rays.jsonl "$n"
}

# Each section runs in order; one that fails is reported and the next still runs (a device lease is short).
for s in $sections; do
  fn=section_${s//-/_}
  declare -F "$fn" >/dev/null || { echo "run_gpu: unknown section $s" >&2; exit 2; }
  start=$SECONDS
  set +e
  (set -e; "$fn")  # a subshell, so that -e still stops the section at its first failure
  rc=$?
  set -e
  [ $rc = 0 ] || echo "run_gpu: section $s failed (exit $rc)"
  echo "{\"bench\":\"section\",\"section\":\"$s\",\"exit\":$rc,\"seconds\":$((SECONDS - start))}" | tee -a "$out/gpu.jsonl"
done
echo "== done: $out/gpu.jsonl"
