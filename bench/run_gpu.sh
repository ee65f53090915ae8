#!/usr/bin/env bash
# Every GPU figure of bench/README.md ("GPU") in one run, on a machine with a GPU: the LOD engine's frame time and
# accuracy against the exact engine (run_lod_render.sh, stores at --error 0.01 and 0), the exact engine on all cores,
# time-critical rendering at 30 and 60 fps and out of core (run_time_critical.sh), and the viewer's EGL path
# (view_socket_check.py: the scene's GL renderer, first frame, input-to-frame latency, a full-quality frame).
# Usage: bench/run_gpu.sh [OUT_DIR=bench/results/gpu] [SCRATCH=/tmp/ugvr-gpu]
#   UGVR (default build/ugvr), UGVR_DATA (default ../shared/data), PYTHON (default python3 on the PATH),
#   SIZE (default 1024), QUICK=1: tiny sizes and frame counts, to check the script itself on llvmpipe.
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

echo "== LOD engine vs exact (run_lod_render.sh)"
for e in $errors; do
  for s in $lod_sizes; do
    n=$(lines bench/results/lod_render.jsonl)
    ERROR=$e SIZE=$s FRAMES=$frames bash bench/run_lod_render.sh "$out/lod-e$e-$s" "$scratch"
    collect bench/results/lod_render.jsonl "$n"
  done
done

echo "== exact engine, all cores ($(nproc))"
for name in blunt-fin lox-post; do
  case $name in
    blunt-fin) field=Density inputs=("$UGVR_DATA/blunt-fin/bluntfinxyz.bin" "$UGVR_DATA/blunt-fin/bluntfinq.bin") ;;
    lox-post) field=StagnationEnergy inputs=("$UGVR_DATA/lox-post/postxyz.bin" "$UGVR_DATA/lox-post/postq.bin") ;;
  esac
  "$UGVR" --quiet render "${inputs[@]}" --field "$field" --camera "bench/results/exact-render/$name-camera.json" \
    --tf "bench/results/exact-render/$name-tf.json" --size "$size" --frames $((frames / 2 + 1)) \
    -o "$scratch/exact.png" --stats "$scratch/exact.json"
  "$PYTHON" -c "import json,sys; s=json.load(open('$scratch/exact.json')); print(json.dumps({'bench':'exact_render','dataset':'$name','size':$size,'threads':s.get('threads'),'median_frame_seconds':s['median_frame_seconds'],'median_frame_cpu_seconds':s.get('median_frame_cpu_seconds')}, separators=(',',':')))" |
    tee -a "$out/gpu.jsonl"
done

echo "== time-critical (run_time_critical.sh)"
n=$(lines bench/results/time_critical.jsonl)
if [[ -n $quick ]]; then
  SIZE=$size FPS=30 FAST_FPS=60 FRAMES=$tc_frames REST=$rest bash bench/run_time_critical.sh "$out/time-critical" "$scratch"
else
  SIZE=$size FPS=30 FAST_FPS=60 FRAMES=$tc_frames REST=$rest OOC=1 bash bench/run_time_critical.sh \
    "$out/time-critical" "$scratch"
fi
collect bench/results/time_critical.jsonl "$n"

echo "== viewer over its socket (view_socket_check.py)"
"$PYTHON" bench/view_socket_check.py "$UGVR" "$scratch/lox-post-e0.01.ugvr" "$out/view" --size "${size}x768" \
  --moves "$moves" --fps 30 | tee -a "$out/gpu.jsonl"

echo "== done: $out/gpu.jsonl"
