#!/usr/bin/env bash
# The hybrid frame of two builds, alternated in one session (A B A B ...): the before/after figure of a change to the
# hybrid pass (docs/hybrid.md), on the scenes, stores, cameras and transfer functions of bench/run_hybrid.sh (run that
# first with either build: it leaves the stores and the exact references in SCRATCH). Each render is checked against
# the exact engine's image (PSNR, `ugvr compare`) and A's image against B's (identical bits or not).
# Usage: bench/run_hybrid_ab.sh UGVR_A UGVR_B [SCRATCH=/tmp/ugvr-hybrid]
#   SHADERS_A, SHADERS_B: each build's UGVR_SHADER_DIR (default: its own, compiled in), SCENES ("blunt-fin
#   lox-post"), SIZE (512), ROUNDS (3), FRAMES (3), PYTHON (python3), EXTRA (more render flags, e.g. "--gpu 0").
# One JSON line per render; per scene a summary: median over the rounds of each build's median frame time (wall and
# the process's CPU time), B/A. On a GPU the device's own timer (gpu_timer_seconds) is the figure to compare.
set -euo pipefail
cd "$(dirname "$0")/.."
a=$1 b=$2
scratch=${3:-/tmp/ugvr-hybrid}
scenes=${SCENES:-blunt-fin lox-post}
size=${SIZE:-512}
rounds=${ROUNDS:-3}
frames=${FRAMES:-3}
py=${PYTHON:-$(command -v python3)}
extra=(${EXTRA:-})
results="$scratch/hybrid-ab.jsonl"
: >"$results"
echo "{\"bench\":\"hybrid_ab_session\",\"date\":\"$(date -u +%FT%TZ)\",\"a\":\"$a\",\"b\":\"$b\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}"
for name in $scenes; do
  case $name in
    blunt-fin) field=Density ;;
    lox-post) field=StagnationEnergy ;;
    *) echo "unknown scene $name" >&2; exit 1 ;;
  esac
  store="$scratch/$name-cells.ugvr" ref="$scratch/$name-exact.pfm"
  for f in "$store" "$ref" "$scratch/$name-tf.json"; do
    [ -f "$f" ] || { echo "$f missing: run bench/run_hybrid.sh first" >&2; exit 1; }
  done
  # The unit distance run_hybrid.sh uses: the data's diagonal / 200.
  unit=$("$a" info "$store" | "$py" -c "
import re, sys, math
for line in sys.stdin:
    if line.strip().startswith('bounds:'):
        v = [float(x) for x in re.findall(r'[-+0-9.eE]+', line)]
        print(math.sqrt((v[1]-v[0])**2 + (v[3]-v[2])**2 + (v[5]-v[4])**2) / 200); break")
  for ((r = 0; r < rounds; ++r)); do
    for which in A B; do
      bin=$a shaders=${SHADERS_A:-}
      [ $which = B ] && bin=$b shaders=${SHADERS_B:-}
      UGVR_SHADER_DIR=$shaders "$bin" --quiet render "$store" --engine hybrid \
        --camera "bench/results/exact-render/$name-camera.json" --tf "$scratch/$name-tf.json" --unit-distance "$unit" \
        --size "$size" --field "$field" "${extra[@]}" --frames "$frames" -o "$scratch/ab-$which.png" \
        --float "$scratch/ab-$which.pfm" --stats "$scratch/ab-stats.json"
      "$b" compare "$scratch/ab-$which.pfm" "$ref" --json "$scratch/ab-cmp.json" >/dev/null
      "$py" -c "
import json
s = json.load(open('$scratch/ab-stats.json')); c = json.load(open('$scratch/ab-cmp.json'))
print(json.dumps({'bench': 'hybrid_ab', 'build': '$which', 'scene': '$name', 'size': $size, 'round': $r,
                  'median_frame_seconds': s['median_frame_seconds'], 'gpu_timer_seconds': s.get('gpu_timer_seconds', 0),
                  'median_frame_cpu_seconds': s.get('median_frame_cpu_seconds', 0),
                  'psnr_db': c['psnr_db'], 'exact_nodes': s['hybrid']['exact_nodes'],
                  'cell_steps': s['hybrid']['cell_steps'], 'cell_bytes': s['hybrid']['cell_bytes'],
                  'renderer': s.get('renderer')}, separators=(',', ':')))" | tee -a "$results"
    done
    cmp -s "$scratch/ab-A.pfm" "$scratch/ab-B.pfm" && same=yes || same=no
    echo "{\"bench\":\"hybrid_ab_bits\",\"scene\":\"$name\",\"round\":$r,\"identical\":\"$same\"}"
  done
done
"$py" - "$results" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for scene in sorted({r["scene"] for r in rows}):
    m = {w: statistics.median(r["median_frame_seconds"] for r in rows if r["scene"] == scene and r["build"] == w)
         for w in "AB"}
    g = {w: statistics.median(r["gpu_timer_seconds"] for r in rows if r["scene"] == scene and r["build"] == w)
         for w in "AB"}
    # The process's CPU time per frame (llvmpipe's threads included): on a machine shared with other work, steadier
    # than the wall time.
    c = {w: statistics.median(r["median_frame_cpu_seconds"] for r in rows if r["scene"] == scene and r["build"] == w)
         for w in "AB"}
    p = {w: [r["psnr_db"] for r in rows if r["scene"] == scene and r["build"] == w][0] for w in "AB"}
    print(json.dumps({"bench": "hybrid_ab_summary", "scene": scene, "a_seconds": m["A"], "b_seconds": m["B"],
                      "b_over_a": m["B"] / m["A"], "a_cpu_seconds": c["A"], "b_cpu_seconds": c["B"],
                      "cpu_b_over_a": c["B"] / c["A"] if c["A"] > 0 else 0, "a_gpu_timer": g["A"], "b_gpu_timer": g["B"],
                      "a_psnr_db": p["A"], "b_psnr_db": p["B"]}, separators=(",", ":")))
PY
