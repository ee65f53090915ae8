#!/usr/bin/env bash
# Time-critical LOD (issue 6): frame times and texel error along a 300-frame orbit, then a rest, on oxygen post with a
# target frame rate and without one; optionally out of core on a generated store of over 2 GiB.
# Usage: bench/run_time_critical.sh [OUT_DIR=bench/results/time-critical] [SCRATCH=/tmp/ugvr-bench]
#   UGVR=path/to/ugvr (default build/ugvr), UGVR_DATA (default ../shared/data), SIZE (512), FPS (10), FRAMES (300),
#   REST (30), GPU (auto), ERROR (store --error, 0.01), FAST_FPS (a second, harder target: 30), CELLS=1 (the store
#   built with --cells and drawn by the hybrid engine: exact cells at rest, the [hybrid] issue's moving-frames check),
#   RUNS ("fps fast full": the runs to make).
#   OOC=1 also runs the out-of-core case: `ugvr generate --cells ${OOC_CELLS:-1600000} --kind hex`, built at --error 0
#   with --float32 and --out-of-core (a store of about 2.4 GiB, ~2 min), rendered with --ram-memory 64MiB and
#   --gpu-memory 32MiB (needs ~2.5 GB of scratch).
# Per run: the per-frame JSON lines of `ugvr render --stats` go to OUT_DIR/NAME.jsonl, and a summary line (share of the
# moving frames after the 10th within 1.2x the target, median and p95 frame time, mean texel error, seconds from the
# camera stopping to full quality) is appended to bench/results/time_critical.jsonl after a `session` line.
# Plot: bench/plot_time_critical.py (docs/img/time-critical.png).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
outdir=${1:-bench/results/time-critical}
scratch=${2:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
size=${SIZE:-512}
fps=${FPS:-10}
frames=${FRAMES:-300}
rest=${REST:-30}
gpu=${GPU:-auto}
error=${ERROR:-0.01}
scenes=bench/results/exact-render
jsonl=bench/results/time_critical.jsonl
mkdir -p "$outdir" "$scratch"
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\",\"lp_num_threads\":\"${LP_NUM_THREADS:-}\"}" | tee -a "$jsonl"

render_path() {  # ugvr render arguments...: runs it, keeps its summary line (the renderer is its last field)
  "$ugvr" render "$@" 2>"$scratch/render.log"
  grep '^rendered' "$scratch/render.log"
}

summarize() {  # NAME FPS(0 = none) STATS.jsonl
  "${PYTHON:-/usr/bin/python3}" - "$1" "$2" "$3" "$frames" "$(grep '^rendered' "$scratch/render.log" | sed 's/.*mean texel error [0-9.]*, //')" <<'EOF' | tee -a "$jsonl"
import json, statistics, sys
name, fps, path, orbit, renderer = sys.argv[1], float(sys.argv[2]), sys.argv[3], int(sys.argv[4]), sys.argv[5]
rows = [json.loads(l) for l in open(path)]
moving = rows[10:orbit]
secs = sorted(r["seconds"] for r in moving)
out = {"bench": "time_critical", "run": name, "fps": fps or None, "frames": len(rows), "orbit_frames": orbit,
       "median_seconds": statistics.median(secs), "p95_seconds": secs[int(0.95 * (len(secs) - 1))],
       "max_seconds": secs[-1],
       "mean_texel_error": statistics.fmean(r["mean_texel_error"] for r in rows[:orbit]),
       "mean_max_texel_error": statistics.fmean(r["max_texel_error"] for r in rows[:orbit]),
       "mean_scale": statistics.fmean(r.get("scale", 1) for r in rows[:orbit]),
       "disk_bytes": sum(r["disk_bytes"] for r in rows), "uploaded_bytes": sum(r["uploaded_bytes"] for r in rows),
       "sync_reads": sum(r["sync_reads"] for r in rows), "renderer": renderer}
if fps:
    target = 1 / fps
    out["within_1_2x"] = sum(s <= 1.2 * target for s in secs) / len(secs)
    out["within_2x"] = sum(s <= 2 * target for s in secs) / len(secs)
# From the camera stopping (the first rest frame) to the first converged frame: frames and seconds.
rest = rows[orbit:]
done = next((i for i, r in enumerate(rest) if r["converged"]), None)
out["rest_frames_to_full_quality"] = None if done is None else done + 1
out["rest_seconds_to_full_quality"] = None if done is None else sum(r["seconds"] for r in rest[:done + 1])
print(json.dumps(out, separators=(",", ":")))
EOF
}

field=StagnationEnergy
cells=(); engine=(); suffix=
if [[ -n ${CELLS:-} ]]; then cells=(--cells); engine=(--engine hybrid); suffix=-cells; fi
runs=${RUNS:-fps fast full}
store="$scratch/lox-post-e$error$suffix.ugvr"
[ -f "$store" ] || "$ugvr" --quiet build "$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin" --fields "$field" \
  --error "$error" "${cells[@]}" -o "$store"
view=(--camera "$scenes/lox-post-camera.json" --tf "$scenes/lox-post-tf.json" --size "$size" --gpu "$gpu" "${engine[@]}")
path="orbit:$frames,rest:$rest"

name=lox-post$suffix
if [[ " $runs " == *" fps "* ]]; then
  render_path "$store" "${view[@]}" --fps "$fps" --path "$path" --stats "$outdir/$name-fps$fps.jsonl" \
    -o "$outdir/$name-fps$fps.png"
  summarize "$name-fps$fps" "$fps" "$outdir/$name-fps$fps.jsonl"
fi
# A target the coarsest cut cannot meet at full size on llvmpipe: the image scale is the lever.
fast=${FAST_FPS:-30}
if [[ " $runs " == *" fast "* ]]; then
  render_path "$store" "${view[@]}" --fps "$fast" --path "$path" --stats "$outdir/$name-fps$fast.jsonl" \
    -o "$outdir/$name-fps$fast.png"
  summarize "$name-fps$fast" "$fast" "$outdir/$name-fps$fast.jsonl"
fi
if [[ " $runs " == *" full "* ]]; then
  render_path "$store" "${view[@]}" --path "$path" --stats "$outdir/$name-full.jsonl" -o "$outdir/$name-full.png"
  summarize "$name-full" 0 "$outdir/$name-full.jsonl"
fi
if [[ " $runs " == *" fps "* && " $runs " == *" full "* ]]; then
  echo "last frame (at rest) with the target vs without: $("$ugvr" compare "$outdir/$name-fps$fps.png" "$outdir/$name-full.png")"
fi

if [[ -n ${OOC:-} ]]; then
  cells=${OOC_CELLS:-1600000}
  mesh="$scratch/generated-$cells.vtu"
  big="$scratch/generated-$cells-e0-f32.ugvr"
  [ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind hex -o "$mesh"
  [ -f "$big" ] || "$ugvr" --quiet build "$mesh" -o "$big" --error 0 --max-depth 10 --fields pressure --float32 \
    --out-of-core --memory 1GiB
  ls -l "$big"
  render_path "$big" --size "$size" --gpu "$gpu" --view iso --fps "$fps" --path "$path" --ram-memory 64MiB \
    --gpu-memory 32MiB --stats "$outdir/generated-ooc-fps$fps.jsonl" -o "$outdir/generated-ooc-fps$fps.png"
  summarize "generated-$cells-ooc-fps$fps" "$fps" "$outdir/generated-ooc-fps$fps.jsonl"
fi
