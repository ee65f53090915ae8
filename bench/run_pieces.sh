#!/usr/bin/env bash
# Partitioned stores (docs/mpi.md, "Partitioned stores"; bench/README.md, "Partitioned stores"): a generated tet mesh
# (CELLS, default 10M) built whole and with --pieces 4 and 8 (in core; build time, total store size, each piece's
# time and peak RSS), then the whole store on 1 rank and the 8-piece index on 1, 2 and 4 ranks (and without MPI)
# at WIDTHxHEIGHT (default 1280x720), FRAMES frames each (the median after the first). One JSON line per run is
# appended to bench/results/pieces.jsonl after a `session` line.
# Usage: bench/run_pieces.sh [UGVR] [WORK]   (default build/ugvr, /tmp/ugvr-bench-pieces); env: CELLS, FRAMES (3),
#   WIDTH, HEIGHT, RANKS ("1 2 4"), PIECES ("4 8"), RENDER_PIECES (8), LP_NUM_THREADS (1: one llvmpipe thread a rank),
#   GHOST_LEVEL (0: --ghost-level, the index files then p<N>-g<L>.json), SKIP_WHOLE (1: reuse WORK/whole.ugvr).
# Ranks beyond the cores are oversubscribed: on a 2-core machine 4 ranks share 2 cores (time slicing included).
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
work=${2:-/tmp/ugvr-bench-pieces}
cells=${CELLS:-10000000}
frames=${FRAMES:-3}
width=${WIDTH:-1280}
height=${HEIGHT:-720}
ranks=${RANKS:-"1 2 4"}
pieces=${PIECES:-"4 8"}
render_pieces=${RENDER_PIECES:-8}
ghost=${GHOST_LEVEL:-0}
tag=$([ "$ghost" = 0 ] && echo "" || echo "-g$ghost")
export LP_NUM_THREADS=${LP_NUM_THREADS:-1}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=bench/results/pieces.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
build="--fields pressure --error 0.01 --max-depth 8"
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "cells": %s, "ghost_level": %s}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$cells" "$ghost" \
  >> "$out"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"

# Builds: the whole store, then each piece count (one process, the pieces one after another).
[ "${SKIP_WHOLE:-0}" = 1 ] || "$ugvr" --quiet build "$mesh" $build -o "$work/whole.ugvr" --json > "$work/whole.json"
[ "${SKIP_WHOLE:-0}" = 1 ] || python3 - "$work/whole.json" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
print(json.dumps({"build": "whole", "load": float(sys.argv[2]), "cells": s["cells"], "seconds": round(s["seconds"], 2),
                  "store_mib": round(s["store_bytes"] / 2**20, 2), "nodes": s["nodes"],
                  "peak_rss_mib": round(s["peak_rss_bytes"] / 2**20, 1)}))
PY
for n in $pieces; do
  "$ugvr" --quiet build "$mesh" $build --pieces "$n" --ghost-level "$ghost" -o "$work/p$n$tag.json" --json \
    > "$work/p$n$tag.out"
  python3 - "$work/p$n$tag.out" "$n" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
b = s["built"]
print(json.dumps({"build": "pieces", "pieces": int(sys.argv[2]), "ghost_level": s["ghost_level"], "load": float(sys.argv[3]), "cells": s["cells"],
                  "seconds": round(s["seconds"], 2), "read_seconds": round(s["read_seconds"], 2),
                  "plan_seconds": round(s["plan_seconds"], 2), "store_mib": round(s["store_bytes_total"] / 2**20, 2),
                  "ghost_margin": s["ghost_margin"], "ghost_cells": sum(p["ghost_cells"] for p in b),
                  "nodes": sum(p["nodes"] for p in b),
                  "piece_seconds": [round(p["seconds"], 2) for p in b],
                  "piece_cells": [p["cells"] + p["ghost_cells"] for p in b],
                  "peak_rss_mib_after_piece": [round(p["peak_rss_bytes"] / 2**20, 1) for p in b]}))
PY
done

# Renders: the whole store on 1 rank, the index on RANKS ranks and in one process without MPI.
render="--size ${width}x${height} --tf viridis --frames $frames"
run_render() {  # label ranks input
  local label=$1 np=$2 input=$3
  if [ "$np" = 0 ]; then
    "$ugvr" --quiet render "$input" $render --stats "$work/s.json" -o "$work/$label-$np.png"
  else
    mpirun --oversubscribe -np "$np" -x LP_NUM_THREADS "$ugvr" --quiet render "$input" $render \
      --stats "$work/s.json" -o "$work/$label-$np.png"
  fi
  python3 - "$work/s.json" "$label" "$np" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
m = s.get("mpi", {})
r = {"render": sys.argv[2], "ranks": int(sys.argv[3]), "load": float(sys.argv[4]),
     "median_frame_seconds": round(s["median_frame_seconds"], 3), "cut_nodes": s.get("cut_nodes")}
if m:
    r.update({"render_seconds_max": round(m["render_seconds_max"], 3), "render_seconds_min": round(m["render_seconds_min"], 3),
              "composite_seconds": round(m["composite_seconds"], 4),
              "rank_render_cpu_seconds": [round(v, 3) for v in m["rank_render_cpu_seconds"]],
              "rank_peak_rss_mib": [round(v / 2**20, 1) for v in m["rank_peak_rss_bytes"]]})
print(json.dumps(r))
PY
}
[ "${SKIP_WHOLE:-0}" = 1 ] || run_render whole 1 "$work/whole.ugvr"
for np in $ranks; do run_render "p$render_pieces$tag" "$np" "$work/p$render_pieces$tag.json"; done
run_render "p$render_pieces$tag" 0 "$work/p$render_pieces$tag.json"
python3 - "$work" "$render_pieces$tag" "$ranks" <<'PY' | tee -a "$out"
import json, sys, subprocess
w, p, ranks = sys.argv[1], sys.argv[2], sys.argv[3].split()
# Each image of the index against the whole store's (PSNR over RGB, as `ugvr compare` prints it).
for np in ranks + ["0"]:
    r = subprocess.run(["build/ugvr", "compare", f"{w}/whole-1.png", f"{w}/p{p}-{np}.png"], capture_output=True, text=True)
    print(json.dumps({"compare": f"p{p} on {np} ranks vs whole", "out": (r.stdout + r.stderr).strip()[:200]}))
PY
