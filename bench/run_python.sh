#!/usr/bin/env bash
# The Python module's figures (issue 19 [python]). Builds nothing: needs build/python (ninja -C build ugvr_python),
# python3-vtk9 and Xvfb.
# Usage: bench/run_python.sh [OUT_DIR=bench/results/python] [SCRATCH=/tmp/ugvr-bench-python]
#   UGVR (default build/ugvr), UGVR_DATA (default ../shared/data), SIZE (384), FRAMES (3), RSS_CELLS (10000000; 0 skips
#   the from_vtk memory run), LOD=0 to leave out the level-of-detail engine, ONLY=blunt-fin|kiefer-bracket|demo for one.
#  1. PyVista's add_volume path (tetrahedralise, cell data to point data, vtkUnstructuredGridVolumeRayCastMapper) vs
#     ugvr.render (exact; lod over a store) on the blunt fin (PLOT3D converted to hexahedra), the kiefer bracket
#     (quadratic tetrahedra, cell data) and the generated mixed demo (200,000 cells): bench/peer_pyvista_style.py,
#     one JSON line per path into bench/results/python_pyvista_style.jsonl, images into OUT_DIR.
#  2. from_vtk's extra peak RSS over VTK's own arrays for a RSS_CELLS-tetrahedra vtkUnstructuredGrid:
#     bench/python_from_vtk_rss.py, into bench/results/python_from_vtk_rss.jsonl.
# Each results file gets a `session` line first (date, commit, machine, load).
set -euo pipefail
cd "$(dirname "$0")/.."
outdir=${1:-bench/results/python}
scratch=${2:-/tmp/ugvr-bench-python}
ugvr=${UGVR:-$PWD/build/ugvr}
data=${UGVR_DATA:-../shared/data}
size=${SIZE:-384}
frames=${FRAMES:-3}
rss_cells=${RSS_CELLS:-10000000}
lod=${LOD:-1}
py=/usr/bin/python3
export PYTHONPATH=$PWD/build/python
mkdir -p "$outdir" "$scratch" bench/results
session="{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"nproc\":$(nproc),\"machine\":\"$(nproc) cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1 /proc/loadavg)\"}"

jsonl=bench/results/python_pyvista_style.jsonl
echo "$session" | tee -a "$jsonl"
"$ugvr" --quiet convert "$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin" "$scratch/blunt-fin.vtu" 2>/dev/null
"$ugvr" --quiet generate -o "$scratch/demo.vtu" --cells 200000 --kind mixed
lod_flag=()
[ "$lod" = 1 ] && lod_flag=(--lod)
# The demo is drawn in its own scene (ugvr.demo(): the camera, transfer function and background of scripts/demo.sh);
# the others in `ugvr render`'s defaults (the oblique view, viridis over the field's range).
"$py" -c "import ugvr, sys; d = ugvr._ugvr._demo_scene(); open(sys.argv[1], 'w').write(d[1]); open(sys.argv[2], 'w').write(d[2])" \
  "$scratch/demo-camera.json" "$scratch/demo-tf.json"
run() {  # name mesh field [extra flags]
  xvfb-run -a -s "-screen 0 1024x768x24" "$py" bench/peer_pyvista_style.py --mesh "$2" --field "$3" --name "$1" \
    --size "$size" --frames "$frames" --out "$outdir" "${lod_flag[@]}" "${@:4}" | tee -a "$jsonl"
}
[ "${ONLY:-}" = "" ] || [ "${ONLY:-}" = blunt-fin ] && run blunt-fin "$scratch/blunt-fin.vtu" Density
[ "${ONLY:-}" = "" ] || [ "${ONLY:-}" = kiefer-bracket ] &&
  run kiefer-bracket "$data/fea-kiefer-bracket/dataset.vtu" "Equivalent (von-Mises) Stress (psi)"
[ "${ONLY:-}" = "" ] || [ "${ONLY:-}" = demo ] && run demo "$scratch/demo.vtu" pressure \
  --camera "$scratch/demo-camera.json" --tf "$scratch/demo-tf.json" --background 0.02,0.02,0.04

if [ "$rss_cells" != 0 ]; then
  jsonl=bench/results/python_from_vtk_rss.jsonl
  echo "$session" | tee -a "$jsonl"
  "$ugvr" --quiet generate -o "$scratch/tet.vtu" --cells "$rss_cells" --kind tet
  "$py" bench/python_from_vtk_rss.py "$scratch/tet.vtu" | tee -a "$jsonl"
  rm -f "$scratch/tet.vtu"
fi
