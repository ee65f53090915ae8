#!/usr/bin/env bash
# LOD frame time of two builds, alternated in one session (A B A B ...), on the scenes of run_lod_render.sh: the
# before/after figure of a change to the LOD engine. Also checks that both builds draw the same bits.
# Usage: bench/run_lod_ab.sh UGVR_A UGVR_B [SCRATCH=/tmp/ugvr-ab]
#   UGVR_DATA (default ../shared/data), SIZES (default "1024 2048"), ROUNDS (3), FRAMES (10), CUT (pixels:1),
#   PYTHON (default python3 on the PATH). One JSON line per render on stdout; a summary (median of the rounds'
#   median frame times, A and B, and B/A) at the end.
set -euo pipefail
cd "$(dirname "$0")/.."
a=$1 b=$2
scratch=${3:-/tmp/ugvr-ab}
data=${UGVR_DATA:-../shared/data}
sizes=${SIZES:-1024 2048}
rounds=${ROUNDS:-3}
frames=${FRAMES:-10}
cut=${CUT:-pixels:1}
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
  for size in $sizes; do
    for ((r = 0; r < rounds; ++r)); do
      for which in A B; do
        bin=$a
        [ $which = B ] && bin=$b
        "$bin" --quiet render "$store" --engine lod --cut "$cut" --camera "bench/results/exact-render/$name-camera.json" \
          --tf "bench/results/exact-render/$name-tf.json" --size "$size" --frames "$frames" -o "$scratch/$which.pfm" \
          --stats "$scratch/stats.json"
        "$py" -c "import json; s=json.load(open('$scratch/stats.json')); print(json.dumps({'bench':'lod_ab','build':'$which','dataset':'$name','size':$size,'round':$r,'median_frame_seconds':s['median_frame_seconds'],'readback_seconds':s['readback_seconds'],'gpu_seconds':s['gpu_seconds'],'renderer':s['renderer']}, separators=(',',':')))" |
          tee -a "$results"
      done
      cmp -s "$scratch/A.pfm" "$scratch/B.pfm" && same=yes || same=no
      echo "{\"bench\":\"lod_ab_bits\",\"dataset\":\"$name\",\"size\":$size,\"identical\":\"$same\"}"
    done
  done
done
"$py" - "$results" <<'EOF'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
for key in sorted({(r["dataset"], r["size"]) for r in rows}):
    m = {w: statistics.median(r["median_frame_seconds"] for r in rows if (r["dataset"], r["size"]) == key and r["build"] == w)
         for w in "AB"}
    rb = {w: statistics.median(r["readback_seconds"] for r in rows if (r["dataset"], r["size"]) == key and r["build"] == w)
          for w in "AB"}
    print(json.dumps({"bench": "lod_ab_summary", "dataset": key[0], "size": key[1], "a_seconds": m["A"],
                      "b_seconds": m["B"], "b_over_a": m["B"] / m["A"], "a_readback": rb["A"], "b_readback": rb["B"]},
                     separators=(",", ":")))
EOF
