#!/usr/bin/env bash
# The exact engine on the GPU against the CPU engine on a generated tetrahedral mesh of N cells at SIZE² (the view
# where llvmpipe's loop limit cut rays short: shaders/loop_limit_probe.glsl, docs/gpu-exact.md "llvmpipe's loop
# limit"). Renders on the GPU (default camera, saved), then on the CPU with that camera; counts pixels left as the bare
# background where the CPU's are not ("lost") and pixels more than 25/255 off (bench/hybrid_lost_rays.py), and the
# rays the GPU engine traced on the CPU (--stats cpu_traced_rays). One JSON line a run in
# bench/results/exact_gpu_loop_limit.jsonl.
# Usage: bench/run_exact_gpu_loop_limit.sh [N=30000000] [SCRATCH=/tmp/ugvr-loop-limit]; UGVR (default build/ugvr), SIZE (1024)
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-30000000}
scratch=${2:-/tmp/ugvr-loop-limit}
ugvr=${UGVR:-$PWD/build/ugvr}
size=${SIZE:-1024}
mkdir -p "$scratch"
vtu="$scratch/tet-$n.vtu"
[ -f "$vtu" ] || "$ugvr" --quiet generate --cells "$n" --kind tet -o "$vtu" >/dev/null
"$ugvr" --quiet render "$vtu" --engine exact --device gpu --tf viridis --field pressure --size "$size" \
  --save-camera "$scratch/camera.json" --stats "$scratch/gpu.json" -o "$scratch/gpu.png"
[ -f "$scratch/cpu.png" ] || "$ugvr" --quiet render "$vtu" --engine exact --device cpu --tf viridis --field pressure \
  --size "$size" --camera "$scratch/camera.json" --stats "$scratch/cpu.json" -o "$scratch/cpu.png"
"$ugvr" compare "$scratch/gpu.png" "$scratch/cpu.png" --json "$scratch/compare.json" >/dev/null
python3 bench/hybrid_lost_rays.py "$scratch/gpu.png" "$scratch/cpu.png" >"$scratch/lost.json"
mkdir -p bench/results
python3 - "$scratch" "$n" "$size" "$(git rev-parse --short HEAD 2>/dev/null || echo unknown)" \
  "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a bench/results/exact_gpu_loop_limit.jsonl
import json, sys
scratch, n, size, commit, load = sys.argv[1:]
g = json.load(open(f"{scratch}/gpu.json"))
c = json.load(open(f"{scratch}/compare.json"))
lost = json.load(open(f"{scratch}/lost.json"))
print(json.dumps({"bench": "exact_gpu_loop_limit", "commit": commit, "device": g.get("device"), "n": int(n),
                  "size": int(size), "lost": lost["lost"], "differing": lost["differing"],
                  "psnr_db": c.get("psnr_db"), "cpu_traced_rays": g.get("cpu_traced_rays"),
                  "rays_hit": g.get("rays_hit"), "reentries": g.get("reentries"),
                  "frame_seconds": g.get("median_frame_seconds"), "load": float(load)}))
PY
