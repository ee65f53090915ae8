#!/usr/bin/env bash
# The exact boundary's frame cost (issue 25): LOD frame times of several (binary, store, shader directory) variants,
# alternated in one session (V1 V2 ... V1 V2 ...), at the exact-render camera and transfer function of a scene, one
# JSON line per render (median frame wall and CPU time of FRAMES frames, and the load) and the medians over the rounds
# with each variant's ratio to the first at the end, then whether each variant's image is the next one's bit for bit.
# Usage: bench/run_faces_ab.sh SCENE LABEL:UGVR:STORE:SHADER_DIR[:ENV] ... (SCENE: blunt-fin, lox-post, or any name
#   with CAMERA and TF set to its files); ENV: VAR=VALUE assignments, comma-separated, for that variant's render
#   (e.g. UGVR_NO_FACE_PLANES=1: the boundary faces without their planes, the shader main had before them).
#   ROUNDS (5), FRAMES (5), SIZE (512), CUT (pixels:1), SCRATCH (/tmp/ugvr-faces-ab), CAMERA and TF (default the
#   scene's in bench/results/exact-render), EXTRA (more render options, e.g. --keep-range).
# The faces off in the same binary and store (the stencil alone, the shader main had before the faces):
#   bench/run_faces_ab.sh --faces-off SHADER_DIR OUT_DIR   copies SHADER_DIR with FACES forced to 0.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = --faces-off ]; then
  rm -rf "$3" && cp -r "$2" "$3"
  python3 - "$3/lod_raycast.comp" <<'PY'
import sys
p = sys.argv[1]
s = open(p).read()
old = '#ifndef FACES\n#define FACES 0'
assert old in s, 'no FACES default in ' + p
open(p, 'w').write(s.replace(old, '#undef FACES\n#define FACES 0\n#if 0', 1))
PY
  exit 0
fi
scene=$1
shift
rounds=${ROUNDS:-5} frames=${FRAMES:-5} size=${SIZE:-512} cut=${CUT:-pixels:1}
scratch=${SCRATCH:-/tmp/ugvr-faces-ab}
mkdir -p "$scratch"
results="$scratch/$scene.jsonl"
: >"$results"
for ((r = 0; r < rounds; ++r)); do
  for spec in "$@"; do
    IFS=: read -r label ugvr store shaders environment <<<"$spec"
    IFS=, read -r -a assignments <<<"${environment:-}"
    # shellcheck disable=SC2086  # EXTRA: options, split on purpose
    env "${assignments[@]}" UGVR_SHADER_DIR="$shaders" "$ugvr" --quiet render "$store" --engine lod --cut "$cut" \
      --camera "${CAMERA:-bench/results/exact-render/$scene-camera.json}" \
      --tf "${TF:-bench/results/exact-render/$scene-tf.json}" ${EXTRA:-} \
      --size "$size" --frames "$frames" -o "$scratch/$label.pfm" --stats "$scratch/stats.json"
    python3 -c "import json; s=json.load(open('$scratch/stats.json')); print(json.dumps({'bench':'faces_ab','scene':'$scene','variant':'$label','round':$r,'wall':s['median_frame_seconds'],'cpu':s['median_frame_cpu_seconds'],'load':float(open('/proc/loadavg').read().split()[0])}, separators=(',', ':')))" |
      tee -a "$results"
  done
done
python3 - "$results" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
order = list(dict.fromkeys(r['variant'] for r in rows))
med = {v: (statistics.median(r['wall'] for r in rows if r['variant'] == v),
           statistics.median(r['cpu'] for r in rows if r['variant'] == v)) for v in order}
w0, c0 = med[order[0]]
loads = [r['load'] for r in rows]
for v in order:
    w, c = med[v]
    print(json.dumps({'bench': 'faces_ab_summary', 'scene': rows[0]['scene'], 'variant': v, 'wall': round(w, 4),
                      'cpu': round(c, 4), 'wall_ratio': round(w / w0, 3), 'cpu_ratio': round(c / c0, 3),
                      'load_min': min(loads), 'load_max': max(loads)}))
PY
# Whether two variants drew the same image (a speed-only change must keep the bits): the largest difference of the
# last round's images, each variant against the next.
python3 - "$scratch" "$@" <<'PY'
import array, json, sys
def pfm(path):
    with open(path, 'rb') as f:
        assert f.readline().strip() in (b'PF', b'Pf'), path + ': not a PFM'
        f.readline()
        f.readline()
        return array.array('f', f.read())
labels = [spec.split(':')[0] for spec in sys.argv[2:]]
for a, b in zip(labels, labels[1:]):
    ia, ib = pfm(f'{sys.argv[1]}/{a}.pfm'), pfm(f'{sys.argv[1]}/{b}.pfm')
    diff = max((abs(x - y) for x, y in zip(ia, ib)), default=0.0) if len(ia) == len(ib) else None
    print(json.dumps({'bench': 'faces_ab_images', 'a': a, 'b': b, 'same_bits': ia.tobytes() == ib.tobytes(),
                      'max_abs_diff': diff}))
PY
