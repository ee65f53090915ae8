#!/usr/bin/env bash
# The frame cost of smooth brush edges (the [hybrid] issue 17, docs/hybrid.md "Smooth brush edges"): oxygen post
# (StagnationEnergy), `--engine lod --cut leaves` at SIZE² with the camera of bench/results/exact-render and the steep
# transfer function of bench/run_hybrid.sh (opacity rising over 0.7..0.8 of the field's range), a focus on the drawn
# field over 0.65..0.85 of its range:
#   A: without an edge (the node-level rule, as before the edges), with UGVR_BEFORE when set (an older binary),
#   B: the same without an edge with UGVR (this build),
#   C: with an edge of 0.05 of the range (the per-sample window) with UGVR.
# Alternated ROUNDS times, FRAMES frames each; prints per run the median frame wall and CPU seconds (`--stats`, the
# first frame left out) and per round the ratios C/B and B/A of the CPU seconds (llvmpipe: the shader runs on the CPU).
# Usage: bench/run_focus_edge.sh [SCRATCH=/tmp/ugvr-focus-edge]
#   UGVR (default build/ugvr), UGVR_BEFORE (default: none, A is skipped), UGVR_DATA (default ../shared/data),
#   SIZE (512), FRAMES (5), ROUNDS (3), PYTHON (python3).
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=${1:-/tmp/ugvr-focus-edge}
ugvr=${UGVR:-$PWD/build/ugvr}
before=${UGVR_BEFORE:-}
data=${UGVR_DATA:-../shared/data}
size=${SIZE:-512}
frames=${FRAMES:-5}
rounds=${ROUNDS:-3}
py=${PYTHON:-$(command -v python3)}
mkdir -p "$scratch"
field=StagnationEnergy
inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin")
store=$scratch/lox-post.ugvr
[ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$field" -o "$store"
cat >"$scratch/tf.json" <<JSON
[{"Name": "steep", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.267, 0.005, 0.329, 0.7, 0.128, 0.567, 0.551, 0.8, 0.369, 0.789, 0.383, 1.0, 0.993, 0.906, 0.144],
  "Points": [0.0, 0.0, 0.5, 0.0, 0.7, 0.0, 0.5, 0.0, 0.8, 0.9, 0.5, 0.0, 1.0, 0.9, 0.5, 0.0]}]
JSON
json_get() { "$py" -c "import json,sys; j=json.load(open(sys.argv[1])); print(eval('j' + sys.argv[2]))" "$1" "$2"; }
# The field's range and the unit distance (diagonal / 200, as bench/run_hybrid.sh) from one small frame's stats.
"$ugvr" --quiet render "$store" --engine lod --field "$field" --size 16 --stats "$scratch/probe.json" \
  -o "$scratch/probe.png"
lo=$(json_get "$scratch/probe.json" '["field_range"][0]')
hi=$(json_get "$scratch/probe.json" '["field_range"][1]')
read -r f0 f1 edge < <("$py" -c "
w = $hi - $lo
print(repr($lo + 0.65 * w), repr($lo + 0.85 * w), repr(0.05 * w))")
unit=$("$ugvr" info "$store" | "$py" -c "
import re, sys, math
for line in sys.stdin:
    if line.startswith('bounds:'):
        v = [float(x) for x in re.findall(r'[-+0-9.eE]+', line)]
        print(math.sqrt((v[1]-v[0])**2 + (v[3]-v[2])**2 + (v[5]-v[4])**2) / 200); break")
view=(--engine lod --cut leaves --camera bench/results/exact-render/lox-post-camera.json --tf "$scratch/tf.json"
  --unit-distance "$unit" --size "$size" --field "$field" --frames "$frames")
run() {  # BINARY FOCUS NAME: prints "wall cpu" medians
  "$1" --quiet render "$store" "${view[@]}" --focus "$2" --stats "$scratch/$3.json" -o "$scratch/$3.png"
  echo "$(json_get "$scratch/$3.json" '["median_frame_seconds"]') $(json_get "$scratch/$3.json" '["median_frame_cpu_seconds"]')"
}
echo "store $store, focus $field:$f0:$f1 (edge $edge), ${size}², $frames frames, commit $(git rev-parse --short HEAD)"
for r in $(seq "$rounds"); do
  a="- -"
  [ -n "$before" ] && a=$(run "$before" "$field:$f0:$f1" a)
  b=$(run "$ugvr" "$field:$f0:$f1" b)
  c=$(run "$ugvr" "$field:$f0:$f1~$edge" c)
  ratio=$("$py" -c "
a, b, c = '$a'.split()[1], float('$b'.split()[1]), float('$c'.split()[1])
print('C/B %.3f' % (c / b), '' if a == '-' else 'B/A %.3f' % (b / float(a)))")
  echo "round $r: A $a  B $b  C $c  (wall, cpu s)  $ratio  load $(cut -d' ' -f1 /proc/loadavg)"
done
