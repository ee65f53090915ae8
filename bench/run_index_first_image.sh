#!/usr/bin/env bash
# Where the first image of a partitioned store's index goes (bench/README.md, "[first-image] issue 24: the index's
# first image, a first look"): `ugvr render INDEX` of a PIECES-piece index (default 16; built in core with
# `ugvr build MESH --pieces N` when WORK has none) against `ugvr render` of its piece 0 alone, ROUNDS rounds
# (default 3) alternating. Per run: wall and CPU (user + system, all threads: llvmpipe's included) seconds from
# /usr/bin/time, and from --stats the store opening ("load_seconds") and the frame's wall and CPU seconds. On a loaded
# machine wall is several times CPU; CPU says what the work is. A generated tet mesh of CELLS cells (default 200000);
# 256², pressure, viridis, the iso view. One JSON line per run in bench/results/index_first_image.jsonl after a
# `session` line.
# Usage: bench/run_index_first_image.sh [UGVR] [WORK]   (default build/ugvr, /tmp/ugvr-bench-index-first-image)
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
work=${2:-/tmp/ugvr-bench-index-first-image}
cells=${CELLS:-200000}
pieces=${PIECES:-16}
rounds=${ROUNDS:-3}
out=bench/results/index_first_image.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
index=$work/p$pieces.json
view="--size 256 --field pressure --tf viridis --view iso"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"
[ -f "$index" ] || "$ugvr" --quiet build "$mesh" --pieces "$pieces" --fields pressure -o "$index" > /dev/null
printf '{"session": "%s", "commit": "%s", "ugvr": "%s", "nproc": %s, "load": "%s", "cells": %s, "pieces": %s}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$ugvr" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" \
  "$cells" "$pieces" >> "$out"
for r in $(seq "$rounds"); do
  for what in piece index; do
    input=$index
    [ "$what" = piece ] && input=${index%.json}.d/piece-0.ugvr
    /usr/bin/time -f '%e %U %S' -o "$work/time.txt" "$ugvr" render "$input" -o "$work/$what.png" $view \
      --stats "$work/stats.json" > /dev/null 2>&1
    read -r wall user sys < "$work/time.txt"
    python3 - "$work/stats.json" "$r" "$what" "$wall" "$user" "$sys" "$(cut -d' ' -f1 /proc/loadavg)" <<'PY' | tee -a "$out"
import json, sys
s = json.load(open(sys.argv[1]))
r, what, wall, user, system, load = sys.argv[2:]
print(json.dumps({"round": int(r), "run": what, "wall_seconds": float(wall), "cpu_seconds": round(float(user) + float(system), 2),
                  "open_seconds": round(s.get("load_seconds", 0), 3), "frame_seconds": round(s["median_frame_seconds"], 3),
                  "frame_cpu_seconds": round(s["median_frame_cpu_seconds"], 3), "load": load}))
PY
  done
done
