#!/usr/bin/env bash
# Exact CPU ray caster vs VTK 9.1 (issue: exact render benchmark). Builds nothing.
# Usage: bench/run_exact_render.sh [OUT_DIR=bench/results/exact-render] [SCRATCH=/tmp/ugvr-bench]
#   UGVR=path/to/ugvr (default build/ugvr), UGVR_DATA (default ../shared/data), FRAMES (default 6), SIZE (512),
#   MAPPERS (default "bunyk pt zsweep"; "" for none), ZSWEEP_FRAMES (default FRAMES; ZSweep costs ~45 CPU-s a frame
#   on the blunt fin and ~200 CPU-s on the oxygen post at 512x512), EXTRA_BUNYK_INTEGRATORS (default "partial": one
#   more Bunyk run per dataset with that ray integrator, closer to exact integration than VTK's default
#   pre-integration table; "" for none),
#   DATASETS (default "blunt-fin lox-post"), SKIP_UGVR=1 to run the VTK side only, DEVICES (default "cpu gpu": the
#   exact engine on the CPU and on the GPU engine through EGL — llvmpipe on a machine without a GPU).
# For each dataset (blunt fin 187,395 tets / Density; oxygen post 513,375 tets / StagnationEnergy):
#  1. `ugvr refine --levels 0 --split five` cuts the PLOT3D grid into 5 tets per hexahedron (`ugvr convert` keeps
#     hexahedra and has no split option) -> SCRATCH/NAME.vtu;
#  2. writes OUT_DIR/NAME-camera.json (ugvr camera JSON: VTK-ResetCamera-like view of the bounds along -z, 30 degrees)
#     and OUT_DIR/NAME-tf.json (ParaView preset: 5 viridis points over the field range, opacity 0 -> 0.5, unit distance
#     = bounds diagonal / 100);
#  3. runs bench/peer_vtk_render.py for each VTK mapper under one Xvfb (/usr/bin/time -v for peak RSS), saving
#     OUT_DIR/NAME-vtk-MAPPER.{pfm,png};
#  4. run_ugvr (below): `ugvr render --engine exact` on the same inputs (skipped if the binary has no such engine),
#     saving OUT_DIR/NAME-ugvr-exact.{png,pfm}.
# One JSON line per run is appended to bench/results/exact_render_vtk.jsonl (VTK) and exact_render_ugvr.jsonl (ugvr),
# after a `session` line (date, commit, machine, nproc, load).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
outdir=${1:-bench/results/exact-render}
scratch=${2:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
frames=${FRAMES:-6}
zsweep_frames=${ZSWEEP_FRAMES:-$frames}
size=${SIZE:-512}
mappers=${MAPPERS-bunyk pt zsweep}
datasets=${DATASETS:-blunt-fin lox-post}
extra_integrators=${EXTRA_BUNYK_INTEGRATORS-partial}
py=/usr/bin/python3
vtk_jsonl=bench/results/exact_render_vtk.jsonl
ugvr_jsonl=bench/results/exact_render_ugvr.jsonl
mkdir -p "$outdir" "$scratch" bench/results
[ -x "$ugvr" ] || { echo "run_exact_render: no ugvr binary at $ugvr (set UGVR=...)" >&2; exit 1; }
[ -d "$data/blunt-fin" ] && [ -d "$data/lox-post" ] || { echo "run_exact_render: datasets not found under $data (set UGVR_DATA=...)" >&2; exit 1; }
nproc=$(nproc)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
session="{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"nproc\":$nproc,\"machine\":\"$nproc cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1 /proc/loadavg)\"}"
echo "$session" | tee -a "$vtk_jsonl"

# ---- one Xvfb for all VTK runs ---------------------------------------------------------------------------------------
xvfb_pid=
start_xvfb() {
  local d
  for d in $(seq 91 140); do
    [ -e "/tmp/.X$d-lock" ] || [ -e "/tmp/.X11-unix/X$d" ] && continue
    /usr/bin/Xvfb ":$d" -screen 0 1024x768x24 -nolisten tcp >/dev/null 2>&1 &
    xvfb_pid=$!
    sleep 1
    if kill -0 "$xvfb_pid" 2>/dev/null; then export DISPLAY=":$d"; return 0; fi
  done
  echo "run_exact_render: could not start Xvfb" >&2; exit 1
}
stop_xvfb() { [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null || true; }
trap stop_xvfb EXIT

# ---- inputs -----------------------------------------------------------------------------------------------------------
# prepare NAME GRID Q FIELD EXPECTED_TETS: NAME.vtu (5 tets per hex), NAME-camera.json, NAME-tf.json
prepare() {
  local name=$1 grid=$2 q=$3 field=$4 expect=$5 mesh="$scratch/$1.vtu"
  if [ ! -s "$mesh" ]; then
    "$ugvr" --quiet refine "$grid" "$q" -o "$mesh" --levels 0 --split five >/dev/null
  fi
  "$ugvr" --quiet info --json "$mesh" >"$scratch/$name-info.json"
  $py - "$scratch/$name-info.json" "$field" "$expect" "$outdir/$name-camera.json" "$outdir/$name-tf.json" <<'EOF'
import json, math, sys
info, field, expect, cam_path, tf_path = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5]
d = json.load(open(info))
if d["cells"] != expect:
    sys.exit(f"run_exact_render: {info}: {d['cells']} cells, expected {expect} tets")
lo, hi = d["bounds"]["min"], d["bounds"]["max"]
f = next(f for b in d["blocks"] for f in b["fields"] if f["name"] == field)
r0, r1 = f["range"]
# VTK vtkRenderer::ResetCamera: focal point = bounds centre, radius = half the diagonal, distance = radius/sin(angle/2),
# camera on +z looking down -z, view up +y, parallel scale = radius.
centre = [(a + b) / 2 for a, b in zip(lo, hi)]
diag = math.dist(lo, hi)
radius = diag / 2
angle = 30.0
dist = radius / math.sin(math.radians(angle / 2))
cam = {"position": [centre[0], centre[1], centre[2] + dist], "focal_point": centre, "view_up": [0.0, 1.0, 0.0],
       "view_angle": angle, "parallel_projection": False, "parallel_scale": radius}
json.dump(cam, open(cam_path, "w"), indent=1)
viridis = [(0.267004, 0.004874, 0.329415), (0.229739, 0.322361, 0.545706), (0.127568, 0.566949, 0.550556),
           (0.369214, 0.788888, 0.382914), (0.993248, 0.906157, 0.143936)]
rgb = []
for i, c in enumerate(viridis):
    rgb += [r0 + (r1 - r0) * i / (len(viridis) - 1), *c]
tf = [{"Name": f"viridis-ramp {field}", "ColorSpace": "RGB", "RGBPoints": rgb,
       "Points": [r0, 0.0, 0.5, 0.0, r1, 0.5, 0.5, 0.0], "ScalarOpacityUnitDistance": diag / 100}]
json.dump(tf, open(tf_path, "w"), indent=1)
print(f"{info}: {d['cells']} tets, {field} [{r0:.6g}, {r1:.6g}], diagonal {diag:.6g}, camera distance {dist:.6g}")
EOF
}

# ---- VTK side ---------------------------------------------------------------------------------------------------------
# run_vtk NAME FIELD MAPPER [INTEGRATOR]
run_vtk() {
  local name=$1 field=$2 mapper=$3 integ=${4:-auto} tag mesh="$scratch/$1.vtu" line rc=0
  local n=$frames load; [ "$mapper" = zsweep ] && n=$zsweep_frames
  load=$(cut -d' ' -f1 /proc/loadavg)
  tag="$name-vtk-$mapper"; [ "$integ" = auto ] || tag="$tag-$integ"
  /usr/bin/time -v -o "$scratch/$tag.time" $py bench/peer_vtk_render.py --mesh "$mesh" --field "$field" \
    --camera "$outdir/$name-camera.json" --tf "$outdir/$name-tf.json" --size "$size" --mapper "$mapper" \
    --integrator "$integ" --frames "$n" --out "$outdir/$tag.pfm" --png "$outdir/$tag.png" --json \
    >"$scratch/$tag.out" 2>"$scratch/$tag.err" || rc=$?
  local rss_kb wall
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/$tag.time" 2>/dev/null || echo 0)
  wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$scratch/$tag.time" 2>/dev/null || echo "")
  line=$(grep '^{' "$scratch/$tag.out" | tail -n 1 || true)
  if [ "$rc" -ne 0 ] || [ -z "$line" ]; then
    echo "{\"bench\":\"render-vtk\",\"dataset\":\"$name\",\"mapper\":\"$mapper\",\"integrator\":\"$integ\",\"error\":\"exit $rc\",\"stderr\":$($py -c 'import json,sys; print(json.dumps(sys.stdin.read()[-400:]))' <"$scratch/$tag.err"),\"nproc\":$nproc}" | tee -a "$vtk_jsonl"
    return 0
  fi
  $py -c 'import json,sys; r=json.loads(sys.argv[1]); r={"dataset":sys.argv[2],**r}; r.update(median=r["median_after_first"], wall=sys.argv[3], time_v_peak_rss_bytes=int(sys.argv[4] or 0)*1024, nproc=int(sys.argv[5]), load_before=float(sys.argv[6]), load_after=float(open("/proc/loadavg").read().split()[0]), image=sys.argv[7]); print(json.dumps(r))' \
    "$line" "$name" "$wall" "$rss_kb" "$nproc" "$load" "$outdir/$tag.png" | tee -a "$vtk_jsonl"
}

# ---- ugvr side --------------------------------------------------------------------------------------------------------
# run_ugvr NAME FIELD DEVICE: >>> THE UGVR EXACT ENGINE RUN <<< on the same mesh, camera, transfer function (already over the
# field range: --keep-range) and background; its --stats JSON has "median_frame_seconds". Reports itself skipped when
# the binary has no `render --engine`; a failure is logged as an error line and does not stop the VTK runs.
run_ugvr() {
  local name=$1 field=$2 device=$3 mesh="$scratch/$1.vtu" tag="$1-ugvr-exact-$3" rc=0 rss_kb load
  if [ -n "${SKIP_UGVR:-}" ] || ! "$ugvr" render --help 2>/dev/null | grep -- '--engine' >/dev/null; then  # not grep -q: under pipefail its early exit fails the pipe
    echo "run_exact_render: skipped ugvr exact engine on $name (no \`ugvr render --engine\` in $ugvr)" >&2
    return 0
  fi
  [ -n "${ugvr_session_done:-}" ] || { echo "$session" >>"$ugvr_jsonl"; ugvr_session_done=1; }
  load=$(cut -d' ' -f1 /proc/loadavg)
  rm -f "$scratch/$tag-stats.json"
  /usr/bin/time -v -o "$scratch/$tag.time" "$ugvr" render "$mesh" --engine exact -o "$outdir/$tag.png" \
    --camera "$outdir/$name-camera.json" --tf "$outdir/$name-tf.json" --keep-range --field "$field" --size "$size" \
    --background 0.32,0.34,0.43 --frames "$frames" --device "$device" --stats "$scratch/$tag-stats.json" --float "$outdir/$tag.pfm" \
    >"$scratch/$tag.out" 2>"$scratch/$tag.err" || rc=$?
  rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/$tag.time" 2>/dev/null || echo 0)
  if [ "$rc" -ne 0 ] || [ ! -s "$scratch/$tag-stats.json" ]; then
    echo "{\"bench\":\"render-ugvr\",\"dataset\":\"$name\",\"engine\":\"exact\",\"device\":\"$device\",\"error\":\"exit $rc\",\"stderr\":$($py -c 'import json,sys; print(json.dumps(sys.stdin.read()[-400:]))' <"$scratch/$tag.err"),\"nproc\":$nproc}" | tee -a "$ugvr_jsonl"
    return 0
  fi
  $py -c 'import json,sys; s=json.load(open(sys.argv[1])); print(json.dumps({"bench":"render-ugvr","dataset":sys.argv[2],"engine":"exact","device":sys.argv[7],"median":s.get("median_frame_seconds"),"stats":s,"time_v_peak_rss_bytes":int(sys.argv[3] or 0)*1024,"nproc":int(sys.argv[4]),"load_before":float(sys.argv[5]),"load_after":float(open("/proc/loadavg").read().split()[0]),"image":sys.argv[6]}))' \
    "$scratch/$tag-stats.json" "$name" "$rss_kb" "$nproc" "$load" "$outdir/$tag.png" "$device" | tee -a "$ugvr_jsonl"
}

# ---- main -------------------------------------------------------------------------------------------------------------
case " $datasets " in *" blunt-fin "*) prepare blunt-fin "$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin" Density 187395 ;; esac
case " $datasets " in *" lox-post "*) prepare lox-post "$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin" StagnationEnergy 513375 ;; esac
start_xvfb
for name in $datasets; do
  case $name in blunt-fin) field=Density ;; lox-post) field=StagnationEnergy ;; *) echo "unknown dataset $name" >&2; exit 1 ;; esac
  for m in $mappers; do run_vtk "$name" "$field" "$m"; done
  for integ in $extra_integrators; do run_vtk "$name" "$field" bunyk "$integ"; done
  for device in ${DEVICES:-cpu gpu}; do run_ugvr "$name" "$field" "$device"; done
done
