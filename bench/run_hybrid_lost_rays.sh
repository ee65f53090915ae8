#!/usr/bin/env bash
# The [hybrid] issue's known defect (docs/hybrid.md, "Known defect on llvmpipe": llvmpipe's loop limit): rays of a
# converged hybrid frame that come back as the bare background where the exact engine's image of the same camera is
# not. Since da98369 such rays are drawn from the voxels (--stats loop_limit_voxel_rays), so expect 0 lost there.
# A generated tetrahedral mesh of N cells is built with its leaves' cells (the flags of bench/run_hybrid_ooc.sh),
# drawn once by the hybrid engine at SIZE² (full quality: every candidate exact within a 256 MiB cell budget; the
# camera saved), then by the exact engine (CPU, in core: about 200 bytes a tetrahedron) with that camera;
# bench/hybrid_lost_rays.py counts.
# Usage: bench/run_hybrid_lost_rays.sh [N=30000000] [SCRATCH=/tmp/ugvr-lost-rays]
#   UGVR (default build/ugvr), SIZE (1024), CELL_MEMORY (256MiB: the cell budget, so which nodes are exact)
# Measured (bench/README.md): 30M tetrahedra, 11 lost pixels of 1,048,576 (200 exact nodes).
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-30000000}
scratch=${2:-/tmp/ugvr-lost-rays}
ugvr=${UGVR:-$PWD/build/ugvr}
size=${SIZE:-1024}
cell_memory=${CELL_MEMORY:-256MiB}
mkdir -p "$scratch"
vtu="$scratch/tet-$n.vtu" store="$scratch/tet-$n-cells.ugvr"
[ -f "$vtu" ] || "$ugvr" --quiet generate --cells "$n" --kind tet -o "$vtu" >/dev/null
[ -f "$store" ] || "$ugvr" --quiet build "$vtu" -o "$store" --out-of-core --cells --memory 1GiB --fields pressure \
  --error 0.01 --max-depth 8 >/dev/null
"$ugvr" --quiet render "$store" --engine hybrid --tf viridis --size "$size" --gpu-cell-memory "$cell_memory" \
  --save-camera "$scratch/camera.json" --stats "$scratch/hybrid.json" -o "$scratch/hybrid.png"
"$ugvr" --quiet render "$vtu" --engine exact --tf viridis --size "$size" --camera "$scratch/camera.json" \
  --field pressure -o "$scratch/exact.png"
"$ugvr" compare "$scratch/hybrid.png" "$scratch/exact.png" --json "$scratch/compare.json" >/dev/null
python3 bench/hybrid_lost_rays.py "$scratch/hybrid.png" "$scratch/exact.png" >"$scratch/lost.json"
# One line a run in bench/results/hybrid_lost_rays.jsonl (run_gpu.sh's lost-rays section collects it on a GPU).
mkdir -p bench/results
python3 - "$scratch" "$n" "$size" "$cell_memory" "$(git rev-parse --short HEAD 2>/dev/null || echo unknown)" \
  "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a bench/results/hybrid_lost_rays.jsonl
import json, os, sys
scratch, n, size, cell_memory, commit, load = sys.argv[1:]
h = json.load(open(f"{scratch}/hybrid.json"))
lost = json.load(open(f"{scratch}/lost.json"))
c = json.load(open(f"{scratch}/compare.json"))
hy = h.get("hybrid") or {}
print(json.dumps({"bench": "hybrid_lost_rays", "commit": commit, "renderer": h.get("renderer"), "n": int(n),
                  "size": int(size), "cell_memory": cell_memory, "entry_grid": os.environ.get("UGVR_HYBRID_ENTRY_GRID", "1"),
                  "exact_nodes": hy.get("exact_nodes"), "exact_cells": hy.get("exact_cells"), "lost": lost["lost"],
                  "differing": lost["differing"], "first_lost": lost["first_lost"][:5], "psnr_db": c.get("psnr_db"),
                  "ssim": c.get("ssim"), "load": float(load)}))
PY
