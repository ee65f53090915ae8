#!/usr/bin/env bash
# The billion-cell run ([mpi] issue 20: "generate and build time, store size, peak RSS per rank, frame time at
# 1280x720 per rank count"; [first-image] issue 24: "1B tets ... build time"), as one script that runs unchanged at any
# size (try it small first: `bash bench/run_billion.sh 2000000 /tmp/ugvr-billion-small`):
#   1. ugvr generate --cells N --kind tet                                   (skipped when WORK/tet-N.vtu exists)
#   2. ugvr build tet-N.vtu --pieces PIECES --ghost-level GHOST --out-of-core --memory MEMORY (one process: the
#      pieces one after another, one piece's scratch at a time), under /usr/bin/time -v, with the scratch folders'
#      size sampled every SAMPLE seconds (`du -sb`), and the disk's free space before;
#   3. the index rendered at WIDTHxHEIGHT, FRAMES frames, on each rank count of RANKS (mpirun --oversubscribe: on a
#      2-core machine more ranks than cores share them), each rank one llvmpipe thread; --stats gives the median
#      frame and each rank's render CPU and peak RSS; the 1-rank image is kept (WORK/billion-1.png) for docs/.
# The settings that fit this machine at 1B (bench/README.md, "[mpi] issue 20 / [first-image] issue 24: partitioned
# stores built out of core"): 16 pieces at ghost level 6 (the largest piece 0.13 of the mesh: ~21 GiB of scratch
# beside the 31.4 GiB .vtu) and --memory 6GiB (the points in one slice; below that every piece's soup pass writes
# corner files). Expect about 3.5 h of CPU for the build at 1B on 2 cores.
# One JSON line per step is appended to bench/results/billion.jsonl after a `session` line.
# Usage: bench/run_billion.sh [N=1000000000] [WORK=/work/ugvr-billion]; env: UGVR (build/ugvr), PIECES (16), GHOST (6),
#   MEMORY (6GiB), RANKS ("1 2 4"), FRAMES (3), WIDTH (1280), HEIGHT (720), SAMPLE (10), SKIP_BUILD (1: reuse the index),
#   RESUME (1: `--resume`, keep the pieces an interrupted run finished: the build then spans sessions; its wall and
#   CPU are this run's, each piece's own seconds are in piece_seconds).
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-1000000000}
work=${2:-/work/ugvr-billion}
ugvr=$(realpath "${UGVR:-build/ugvr}")
pieces=${PIECES:-16}
ghost=${GHOST:-6}
memory=${MEMORY:-6GiB}
ranks=${RANKS:-"1 2 4"}
frames=${FRAMES:-3}
width=${WIDTH:-1280}
height=${HEIGHT:-720}
sample=${SAMPLE:-10}
export LP_NUM_THREADS=${LP_NUM_THREADS:-1}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=bench/results/billion.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$n.vtu
index=$work/tet-$n.json
load() { cut -d' ' -f1 /proc/loadavg; }
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "cells": %s, "pieces": %s, "ghost_level": %s, "memory": "%s", "disk_free_bytes": %s}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$n" "$pieces" \
  "$ghost" "$memory" "$(df -B1 --output=avail "$work" | tail -1 | tr -d ' ')" >> "$out"

peak_rss() { awk -F': ' '/Maximum resident set size/ {printf "%.0f\n", $2 * 1024}' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' "$1"; }
cpu() { awk -F': ' '/User time|System time/ {s += $2} END {print s}' "$1"; }

if [ ! -f "$mesh" ]; then
  /usr/bin/time -v "$ugvr" --quiet generate --cells "$n" --kind tet -o "$mesh" >/dev/null 2>"$work/generate.time"
  printf '{"step": "generate", "load": %s, "wall_s": %s, "peak_rss_bytes": %s, "vtu_bytes": %s}\n' "$(load)" \
    "$(wall "$work/generate.time")" "$(peak_rss "$work/generate.time")" "$(stat -c %s "$mesh")" | tee -a "$out"
fi

if [ "${SKIP_BUILD:-0}" != 1 ]; then
  peak_file=$work/scratch.peak
  echo 0 >"$peak_file"
  (
    while :; do
      s=$(find "$work" -maxdepth 3 -type d -name '*.cells' -exec du -sb {} + 2>/dev/null | awk '{t += $1} END {printf "%.0f\n", t}')
      [ "${s:-0}" -gt "$(cat "$peak_file")" ] && echo "$s" >"$peak_file"
      sleep "$sample"
    done
  ) &
  sampler=$!
  trap 'kill $sampler 2>/dev/null || true' EXIT
  /usr/bin/time -v "$ugvr" --quiet build "$mesh" -o "$index" --fields pressure --error 0.01 --max-depth 8 \
    --pieces "$pieces" --ghost-level "$ghost" --out-of-core --memory "$memory" ${RESUME:+--resume} --json >"$work/build.json" \
    2>"$work/build.time"
  kill "$sampler" 2>/dev/null || true
  python3 - "$work/build.json" "$(load)" "$(wall "$work/build.time")" "$(cpu "$work/build.time")" \
    "$(peak_rss "$work/build.time")" "$(cat "$peak_file")" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
b = s["built"]
held = [p["cells"] + p["ghost_cells"] for p in b]
print(json.dumps({"step": "build", "load": float(sys.argv[2]), "wall_s": float(sys.argv[3]), "cpu_s": float(sys.argv[4]),
                  "peak_rss_bytes": int(sys.argv[5]), "scratch_peak_bytes": int(sys.argv[6]), "cells": s["cells"],
                  "cells_held": sum(held), "largest_piece_cells": max(held),
                  "store_bytes": s["store_bytes_total"], "nodes": sum(p["nodes"] for p in b),
                  "plan_seconds": round(s["plan_seconds"], 2),
                  "piece_seconds": [round(p["seconds"], 1) for p in b],
                  "pieces_kept_from_earlier_runs": sum(1 for p in b if p.get("resumed"))}))
PY
fi

for np in $ranks; do
  /usr/bin/time -v mpirun --oversubscribe -np "$np" -x LP_NUM_THREADS "$ugvr" --quiet render "$index" \
    --size "${width}x${height}" --tf viridis --frames "$frames" --stats "$work/render-$np.json" -o "$work/billion-$np.png" \
    >/dev/null 2>"$work/render-$np.time"
  python3 - "$work/render-$np.json" "$np" "$(load)" "$(wall "$work/render-$np.time")" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
m = s.get("mpi", {})
r = {"step": "render", "ranks": int(sys.argv[2]), "load": float(sys.argv[3]), "wall_s": float(sys.argv[4]),
     "median_frame_seconds": round(s["median_frame_seconds"], 3), "cut_nodes": s.get("cut_nodes")}
if m:
    r.update({"render_seconds_max": round(m["render_seconds_max"], 3),
              "composite_seconds": round(m["composite_seconds"], 4),
              "rank_render_cpu_seconds": [round(v, 3) for v in m["rank_render_cpu_seconds"]],
              "rank_peak_rss_bytes": m["rank_peak_rss_bytes"]})
print(json.dumps(r))
PY
done

# 4. The viewer ([first-image] issue 24: "opens in the viewer ... first image time"; [mpi]: "explored in the viewer"):
#    `ugvr view INDEX` in one process (bench/view_socket_check.py: the URL, the first frame, MOVES moving frames at a
#    VIEW_FPS target, a full-quality frame at VIEW_SIZE, the server's peak RSS), then a screenshot of the page at rest
#    (tests/e2e/screenshot.mjs, WORK/billion-view.png) when node, playwright-core and Chromium are there.
view_size=${VIEW_SIZE:-1280x720}
python3 bench/view_socket_check.py "$ugvr" "$index" "$work/view" --size "$view_size" --moves "${MOVES:-10}" \
  --fps "${VIEW_FPS:-2}" >/dev/null
python3 - "$work/view/view_check.json" "$(load)" <<'PY' | tee -a "$out"
import json, sys
v = json.load(open(sys.argv[1]))
keep = ["size", "url_seconds", "first_frame_since_start_seconds", "first_converged_seconds", "latency_median_seconds",
        "frame_seconds_median", "mean_scale_moving", "full_quality_frame_seconds", "server_peak_rss_bytes"]
print(json.dumps(dict({"step": "view", "load": float(sys.argv[2])}, **{k: v[k] for k in keep})))
PY
if command -v node >/dev/null && [ -d tests/e2e/node_modules/playwright-core ] && [ -x "${UGVR_CHROMIUM:-/usr/bin/chromium}" ]; then
  node tests/e2e/screenshot.mjs "$ugvr" "$index" "$work/billion-view.png" >/dev/null
fi
