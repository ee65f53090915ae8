#!/usr/bin/env bash
# Frame times of two builds, alternated in one session (A B A B ...), on the scenes of run_lod_render.sh (blunt fin,
# oxygen post): the before/after figure of a change. The LOD engine renders the stores, the exact engine the PLOT3D
# grids. Also checks that both builds draw the same bits.
# Usage: bench/run_ab.sh UGVR_A UGVR_B [SCRATCH=/tmp/ugvr-ab]
#   UGVR_DATA (default ../shared/data), ENGINES (default "lod exact"), SIZES (default "1024 2048"; the exact engine
#   takes EXACT_SIZES, default "512"), ROUNDS (3), FRAMES (10), CUT (pixels:1), PYTHON (default python3 on the PATH).
#   One JSON line per render on stdout; a summary per engine and scene (median of the rounds' median frame times, A
#   and B, and B/A) at the end.
#   SHADERS_A, SHADERS_B: each build's UGVR_SHADER_DIR (default: the environment's). OWN_STORES=1: each build renders
#   a store it built itself ($name-a.ugvr, $name-b.ugvr), for a change of the store's format (the bits then differ).
set -euo pipefail
cd "$(dirname "$0")/.."
a=$1 b=$2
scratch=${3:-/tmp/ugvr-ab}
data=${UGVR_DATA:-../shared/data}
sizes=${SIZES:-1024 2048}
rounds=${ROUNDS:-3}
frames=${FRAMES:-10}
cut=${CUT:-pixels:1}
engines=${ENGINES:-lod exact}
exact_sizes=${EXACT_SIZES:-512}
py=${PYTHON:-$(command -v python3)}
mkdir -p "$scratch"
results="$scratch/ab.jsonl"
: >"$results"
for name in blunt-fin lox-post; do
  case $name in
    blunt-fin) field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") ;;
    lox-post) field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") ;;
  esac
  store="$scratch/$name.ugvr"
  [ -f "$store" ] || "$a" --quiet build "${inputs[@]}" --fields "$field" --error 0.01 -o "$store"
  if [ "${OWN_STORES:-0}" = 1 ]; then
    [ -f "$scratch/$name-a.ugvr" ] || UGVR_SHADER_DIR=${SHADERS_A:-${UGVR_SHADER_DIR:-}} "$a" --quiet build "${inputs[@]}" \
      --fields "$field" --error 0.01 -o "$scratch/$name-a.ugvr"
    [ -f "$scratch/$name-b.ugvr" ] || UGVR_SHADER_DIR=${SHADERS_B:-${UGVR_SHADER_DIR:-}} "$b" --quiet build "${inputs[@]}" \
      --fields "$field" --error 0.01 -o "$scratch/$name-b.ugvr"
  fi
  for engine in $engines; do
    if [ "$engine" = lod ]; then
      what=("$store" --engine lod --cut "$cut") engine_sizes=$sizes
    else
      what=("${inputs[@]}" --engine exact --field "$field") engine_sizes=$exact_sizes
    fi
    for size in $engine_sizes; do
      for ((r = 0; r < rounds; ++r)); do
        for which in A B; do
          bin=$a shaders=${SHADERS_A:-${UGVR_SHADER_DIR:-}}
          [ $which = B ] && bin=$b shaders=${SHADERS_B:-${UGVR_SHADER_DIR:-}}
          run=("${what[@]}")
          [ "$engine" = lod ] && [ "${OWN_STORES:-0}" = 1 ] && run[0]="$scratch/$name-${which,,}.ugvr"
          UGVR_SHADER_DIR=$shaders "$bin" --quiet render "${run[@]}" --camera "bench/results/exact-render/$name-camera.json" \
            --tf "bench/results/exact-render/$name-tf.json" --size "$size" --frames "$frames" -o "$scratch/$which.pfm" \
            --stats "$scratch/stats.json"
          "$py" -c "import json; s=json.load(open('$scratch/stats.json')); print(json.dumps({'bench':'ab','build':'$which','engine':'$engine','dataset':'$name','size':$size,'round':$r,'median_frame_seconds':s['median_frame_seconds'],'median_frame_cpu_seconds':s.get('median_frame_cpu_seconds',0),'readback_seconds':s.get('readback_seconds',0),'gpu_timer_seconds':s.get('gpu_timer_seconds',0),'renderer':s.get('renderer','CPU %d threads' % s['threads'])}, separators=(',',':')))" |
            tee -a "$results"
        done
        cmp -s "$scratch/A.pfm" "$scratch/B.pfm" && same=yes || same=no
        echo "{\"bench\":\"ab_bits\",\"engine\":\"$engine\",\"dataset\":\"$name\",\"size\":$size,\"identical\":\"$same\"}"
      done
    done
  done
done
"$py" - "$results" <<'EOF'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
def scene(r):
    return (r["engine"], r["dataset"], r["size"])
for key in sorted({scene(r) for r in rows}):
    m = {w: statistics.median(r["median_frame_seconds"] for r in rows if scene(r) == key and r["build"] == w)
         for w in "AB"}
    rb = {w: statistics.median(r["readback_seconds"] for r in rows if scene(r) == key and r["build"] == w)
          for w in "AB"}
    # The process's CPU time per frame: on a machine shared with other work, steadier than the wall time.
    cpu = {w: statistics.median(r.get("median_frame_cpu_seconds", 0) for r in rows if scene(r) == key and r["build"] == w)
           for w in "AB"}
    # The ray-casting dispatch by the device's own clock (last frame's GL timer query; lod only): the readback,
    # which dominates a large frame's wall time on a GPU, left out.
    gt = {w: statistics.median(r.get("gpu_timer_seconds", 0) for r in rows if scene(r) == key and r["build"] == w)
          for w in "AB"}
    print(json.dumps({"bench": "ab_summary", "engine": key[0], "dataset": key[1], "size": key[2], "a_seconds": m["A"],
                      "b_seconds": m["B"], "b_over_a": m["B"] / m["A"], "a_cpu_seconds": cpu["A"], "b_cpu_seconds": cpu["B"],
                      "cpu_b_over_a": cpu["B"] / cpu["A"] if cpu["A"] > 0 else 0, "a_readback": rb["A"], "b_readback": rb["B"],
                      "a_gpu_timer": gt["A"], "b_gpu_timer": gt["B"],
                      "gpu_timer_b_over_a": gt["B"] / gt["A"] if gt["A"] > 0 else 0},
                     separators=(",", ":")))
EOF
