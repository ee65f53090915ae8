#!/usr/bin/env bash
# Peer for the level-of-detail engine: ParaView 5.11's "Resample To Image" volume rendering (pvbatch, Mesa llvmpipe
# under Xvfb) of the blunt fin and the oxygen post, 512x512. Builds nothing; needs scripts/install-bench-deps.sh.
# Usage: bench/run_peer_paraview.sh [OUT_DIR=bench/results/peer-paraview] [SCRATCH=/tmp/ugvr-bench]
#   UGVR=path/to/ugvr (default build/ugvr), UGVR_DATA (default ../shared/data), FRAMES (timed frames after the first,
#   default 5), SIZE (512), RESAMPLE (SamplingDimensions per axis, default "128 256"), DATASETS (default
#   "blunt-fin lox-post"), LP_NUM_THREADS (llvmpipe's rasterizer threads, default nproc),
#   PV_PYTHON_PREFIX (python3-paraview unpacked by install-bench-deps.sh, default /opt/ugvr-bench/python3-paraview).
# For each dataset (blunt fin 187,395 tets / Density; oxygen post 513,375 tets / StagnationEnergy):
#  1. `ugvr refine --levels 0 --split five` cuts the PLOT3D grid into 5 tets per hexahedron -> SCRATCH/NAME.vtu (the
#     meshes of bench/run_exact_render.sh; reused when present);
#  2. writes OUT_DIR/NAME-camera.json (VTK-ResetCamera-like view along -z, 30 degrees) and OUT_DIR/NAME-tf.json (5
#     viridis points over the field range, opacity 0 -> 0.5, unit distance = bounds diagonal / 100), as
#     bench/run_exact_render.sh does;
#  3. for each RESAMPLE size runs bench/peer_paraview_resample.py under pvbatch (one Xvfb for all runs): first frame
#     (the resample + first draw), then FRAMES frames each after a +1 degree camera azimuth; saves
#     OUT_DIR/NAME-pv-resampleN.png.
# One JSON line per run is appended to bench/results/peer-paraview.jsonl after a `session` line; a table of the
# medians is printed at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
outdir=${1:-bench/results/peer-paraview}
scratch=${2:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
frames=${FRAMES:-5}
size=${SIZE:-512}
resample=${RESAMPLE:-128 256}
datasets=${DATASETS:-blunt-fin lox-post}
export LP_NUM_THREADS=${LP_NUM_THREADS:-$(nproc)}
pv_prefix=${PV_PYTHON_PREFIX:-/opt/ugvr-bench/python3-paraview}
py=/usr/bin/python3
jsonl=bench/results/peer-paraview.jsonl
mkdir -p "$outdir" "$scratch" bench/results
[ -x "$ugvr" ] || { echo "run_peer_paraview: no ugvr binary at $ugvr (set UGVR=...)" >&2; exit 1; }
[ -d "$data/blunt-fin" ] && [ -d "$data/lox-post" ] || { echo "run_peer_paraview: datasets not found under $data (set UGVR_DATA=...)" >&2; exit 1; }
command -v pvbatch >/dev/null && [ -x /usr/bin/Xvfb ] || { echo "run_peer_paraview: no pvbatch or Xvfb: run scripts/install-bench-deps.sh" >&2; exit 1; }
# pvbatch's Python modules: python3-paraview if installed, else the copy install-bench-deps.sh unpacked aside (it
# conflicts with python3-vtk9); its dist-packages go first so that ParaView's vtkmodules shadow python3-vtk9's.
if [ ! -f /usr/lib/python3/dist-packages/paraview/simple.py ] || dpkg-query -W -f='${Status}' python3-vtk9 2>/dev/null | grep -q "install ok installed"; then
  [ -f "$pv_prefix/usr/lib/python3/dist-packages/paraview/simple.py" ] || { echo "run_peer_paraview: no python3-paraview in $pv_prefix: run scripts/install-bench-deps.sh" >&2; exit 1; }
  export PYTHONPATH="$pv_prefix/usr/lib/python3/dist-packages${PYTHONPATH:+:$PYTHONPATH}"
fi
nproc=$(nproc)
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
session="{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"nproc\":$nproc,\"machine\":\"$nproc cores, $(awk '/MemTotal/ {printf "%.0f GiB", $2/1048576}' /proc/meminfo), load $(cut -d' ' -f1 /proc/loadavg)\",\"lp_num_threads\":\"$LP_NUM_THREADS\"}"
echo "$session" | tee -a "$jsonl"
first_line=$(wc -l <"$jsonl")  # this session's line

# ---- one Xvfb for all runs ---------------------------------------------------------------------------------------------
xvfb_pid=
start_xvfb() {
  local d ready
  for d in $(seq 91 140); do
    [ -e "/tmp/.X$d-lock" ] || [ -e "/tmp/.X11-unix/X$d" ] && continue
    # Readiness as xvfb-run does it: an X server started with SIGUSR1 ignored sends SIGUSR1 to its parent once it
    # accepts clients (a socket that merely exists is not enough: pvbatch then aborts, "bad X server connection"). It
    # would signal again on each server reset, so -noreset, and the handler stays (SIGUSR1's default action kills).
    ready=
    trap 'ready=1' USR1
    (trap '' USR1; exec /usr/bin/Xvfb ":$d" -screen 0 1024x768x24 -nolisten tcp -noreset >/dev/null 2>&1) &
    xvfb_pid=$!
    for _ in $(seq 1 300); do
      [ -n "$ready" ] && break
      kill -0 "$xvfb_pid" 2>/dev/null || break
      sleep 0.1
    done
    trap : USR1
    if [ -n "$ready" ] && kill -0 "$xvfb_pid" 2>/dev/null; then export DISPLAY=":$d"; return 0; fi
    kill "$xvfb_pid" 2>/dev/null || true
  done
  echo "run_peer_paraview: could not start Xvfb" >&2; exit 1
}
stop_xvfb() { [ -n "$xvfb_pid" ] && kill "$xvfb_pid" 2>/dev/null || true; }
trap stop_xvfb EXIT

# ---- inputs (as bench/run_exact_render.sh) ------------------------------------------------------------------------------
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
    sys.exit(f"run_peer_paraview: {info}: {d['cells']} cells, expected {expect} tets")
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

# ---- ParaView ---------------------------------------------------------------------------------------------------------
# run_pv NAME FIELD N
run_pv() {
  local name=$1 field=$2 n=$3 tag="$1-pv-resample$3" rc=0 line load
  load=$(cut -d' ' -f1 /proc/loadavg)
  echo "run_peer_paraview: $name, resample ${n}^3, ${size}x${size}, $frames frames ..." >&2
  pvbatch --dr bench/peer_paraview_resample.py --mesh "$scratch/$name.vtu" --field "$field" \
    --camera "$outdir/$name-camera.json" --tf "$outdir/$name-tf.json" --size "$size" --resample "$n" \
    --frames "$frames" --dataset "$name" --png "$outdir/$tag.png" --json \
    >"$scratch/$tag.out" 2>"$scratch/$tag.err" || rc=$?
  line=$(grep '^{' "$scratch/$tag.out" | tail -n 1 || true)
  if [ "$rc" -ne 0 ] || [ -z "$line" ]; then
    echo "{\"bench\":\"render-paraview\",\"dataset\":\"$name\",\"resample_dims\":[$n,$n,$n],\"error\":\"exit $rc\",\"stderr\":$($py -c 'import json,sys; print(json.dumps(sys.stdin.read()[-400:]))' <"$scratch/$tag.err"),\"nproc\":$nproc}" | tee -a "$jsonl"
    return 0
  fi
  $py -c 'import json,sys; r=json.loads(sys.argv[1]); r.update(load_before=float(sys.argv[2]), load_after=float(open("/proc/loadavg").read().split()[0]), image=sys.argv[3]); print(json.dumps(r))' \
    "$line" "$load" "$outdir/$tag.png" | tee -a "$jsonl"
}

# ---- main -------------------------------------------------------------------------------------------------------------
case " $datasets " in *" blunt-fin "*) prepare blunt-fin "$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin" Density 187395 ;; esac
case " $datasets " in *" lox-post "*) prepare lox-post "$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin" StagnationEnergy 513375 ;; esac
start_xvfb
for name in $datasets; do
  case $name in blunt-fin) field=Density ;; lox-post) field=StagnationEnergy ;; *) echo "unknown dataset $name" >&2; exit 1 ;; esac
  for n in $resample; do run_pv "$name" "$field" "$n"; done
done

# ---- table ------------------------------------------------------------------------------------------------------------
$py - "$jsonl" "$first_line" <<'EOF'
import json, sys
with open(sys.argv[1]) as f:
    rows = [json.loads(l) for l in f.readlines()[int(sys.argv[2]) - 1:] if l.strip()]
runs = [r for r in rows if r.get("bench") == "render-paraview"]
print()
print("| dataset | resample | median frame s (wall / CPU) | first frame s (resample + first draw) | frames s | peak RSS MiB |")
print("|---|---|---|---|---|---|")
for r in runs:
    d = "x".join(map(str, r.get("resample_dims", [])))
    if "error" in r:
        print(f"| {r['dataset']} | {d} | error: {r['error']} | | | |")
        continue
    fs = " ".join(f"{t:.3f}" for t in r["frames_seconds"])
    print(f"| {r['dataset']} | {d} | {r['median']:.3f} / {r['median_cpu']:.3f} | {r['first_frame_seconds']:.2f} "
          f"({r['update_seconds']:.2f} + {r['first_draw_seconds']:.2f}) | {fs} | {r['peak_rss_bytes'] / 2**20:.0f} |")
ok = [r for r in runs if "error" not in r]
if ok:
    r = ok[0]
    print(f"\nrenderer: {r['gl_renderer']}, {r['gl_version']}; {r['mapper_class']} -> "
          f"{r['options'].get('LastUsedRenderMode')}; LP_NUM_THREADS={r['lp_num_threads']}; "
          f"vtkSMPTools {r['smp_backend']} ({r['smp_threads']} thread(s)); ParaView {r['paraview_version']}")
EOF
