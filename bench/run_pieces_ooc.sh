#!/usr/bin/env bash
# Partitioned stores built out of core (docs/mpi.md, "Partitioned stores", *Out of core*; bench/README.md, "[mpi]
# issue 20 / [first-image] issue 24: pieces built out of core"): a generated tet mesh (CELLS, default 10M) built whole
# out of core and as PIECES (default 8) pieces out of core at --memory MEMORY (default 1GiB), for each ghost level of
# GHOST_LEVELS (default "0 4"). Per build, from `/usr/bin/time -v`: wall, CPU (user + system), peak RSS; the scratch
# folders' peak on disk (`du -sb` of WORK every SAMPLE seconds, default 2: the pieces' "<piece>.ugvr.cells" and the
# whole build's "<store>.cells"; the input and the finished stores are not counted); from --json: the store sizes,
# the cells and ghost cells, the plan's time and split samples. One JSON line per build is appended to
# bench/results/pieces_ooc.jsonl after a `session` line, and a table is printed.
# Usage: bench/run_pieces_ooc.sh [UGVR] [WORK]   (default build/ugvr, /tmp/ugvr-bench-pieces-ooc); env: CELLS, PIECES,
#   MEMORY, GHOST_LEVELS, SAMPLE, SKIP_WHOLE (1: no whole build), REPEATS (1: whole and pieces alternated per repeat).
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
work=${2:-/tmp/ugvr-bench-pieces-ooc}
cells=${CELLS:-10000000}
pieces=${PIECES:-8}
memory=${MEMORY:-1GiB}
ghosts=${GHOST_LEVELS:-"0 4"}
sample=${SAMPLE:-2}
repeats=${REPEATS:-1}
out=bench/results/pieces_ooc.jsonl
mkdir -p bench/results "$work"
mesh=$work/tet-$cells.vtu
build="--fields pressure --error 0.01 --max-depth 8 --out-of-core --memory $memory"
[ -f "$mesh" ] || "$ugvr" --quiet generate --cells "$cells" --kind tet -o "$mesh"
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "cells": %s, "pieces": %s, "memory": "%s", "input_bytes": %s}\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$cells" \
  "$pieces" "$memory" "$(stat -c %s "$mesh")" >> "$out"
runs=$work/runs.jsonl
: > "$runs"

# Runs one build under /usr/bin/time -v while sampling the scratch folders' size; prints its JSON line.
# $1: label, $2: ghost level ("-" for the whole build), rest: the ugvr arguments.
measure() {
  local label=$1 ghost=$2
  shift 2
  local peak_file=$work/scratch.peak
  echo 0 > "$peak_file"
  (
    set +e +o pipefail  # a folder removed while du reads it is no failure here
    peak=0
    while true; do
      s=$(find "$work" -maxdepth 3 -type d -name '*.cells' -exec du -sb {} + 2>/dev/null | awk '{t += $1} END {printf "%.0f\n", t}')
      [ "$s" -gt "$peak" ] && peak=$s && echo "$peak" > "$peak_file"
      sleep "$sample"
    done
  ) &
  local sampler=$!
  local load
  load=$(cut -d' ' -f1 /proc/loadavg)
  /usr/bin/time -v -o "$work/time.txt" "$ugvr" --quiet "$@" --json > "$work/build.json"
  kill "$sampler" 2> /dev/null || true
  wait "$sampler" 2> /dev/null || true
  python3 - "$work/build.json" "$work/time.txt" "$peak_file" "$label" "$ghost" "$load" <<'PY'
import json, re, sys
s = json.loads(open(sys.argv[1]).read().strip().splitlines()[-1])
t = open(sys.argv[2]).read()
def field(name):
    return re.search(re.escape(name) + r":\s*(.+)", t).group(1).strip()
def wall(v):
    parts = [float(p) for p in v.split(":")]
    return sum(p * 60 ** i for i, p in enumerate(reversed(parts)))
r = {"build": sys.argv[4], "ghost_level": None if sys.argv[5] == "-" else int(sys.argv[5]), "load": float(sys.argv[6]),
     "wall_seconds": round(wall(field("Elapsed (wall clock) time (h:mm:ss or m:ss)")), 1),
     "cpu_seconds": round(float(field("User time (seconds)")) + float(field("System time (seconds)")), 1),
     "peak_rss_mib": round(int(field("Maximum resident set size (kbytes)")) / 1024, 1),
     "scratch_peak_mib": round(int(open(sys.argv[3]).read()) / 2**20, 1)}
if "built" in s:
    b = s["built"]
    r.update({"store_mib": round(s["store_bytes_total"] / 2**20, 2), "cells": s["cells"],
              "ghost_cells": sum(p["ghost_cells"] for p in b), "piece_cells": [p["cells"] + p["ghost_cells"] for p in b],
              "plan_seconds": round(s["plan_seconds"], 1), "split_samples": s["split_samples"],
              "piece_seconds": [round(p["seconds"], 1) for p in b], "nodes": sum(p["nodes"] for p in b),
              "leaves_in_pieces": sum(p["leaves_in_pieces"] for p in b)})
else:
    r.update({"store_mib": round(s["store_bytes"] / 2**20, 2), "cells": s["cells"], "nodes": s["nodes"],
              "leaves_in_pieces": s["leaves_in_pieces"]})
print(json.dumps(r))
PY
}

for repeat in $(seq "$repeats"); do
  if [ "${SKIP_WHOLE:-0}" != 1 ]; then
    measure whole - build "$mesh" $build -o "$work/whole.ugvr" | tee -a "$out" >> "$runs"
    rm -f "$work/whole.ugvr"
  fi
  for g in $ghosts; do
    measure pieces "$g" build "$mesh" $build --pieces "$pieces" --ghost-level "$g" -o "$work/p$pieces-g$g.json" |
      tee -a "$out" >> "$runs"
    rm -rf "$work/p$pieces-g$g.d" "$work/p$pieces-g$g.json"
  done
done
python3 - "$runs" <<'PY'
import json, statistics, sys
runs = [json.loads(l) for l in open(sys.argv[1])]
whole = [r for r in runs if r["build"] == "whole"]
w = statistics.median(r["wall_seconds"] for r in whole) if whole else None
print("build | ghost level | wall s | CPU s | peak RSS MiB | scratch peak MiB | stores MiB | cells held (owned + ghost) | wall / whole")
for key in sorted({(r["build"], r["ghost_level"] if r["ghost_level"] is not None else -1) for r in runs}):
    rs = [r for r in runs if r["build"] == key[0] and (r["ghost_level"] if r["ghost_level"] is not None else -1) == key[1]]
    med = lambda k: statistics.median(r[k] for r in rs)
    held = rs[0]["cells"] + rs[0].get("ghost_cells", 0)
    ratio = f'{med("wall_seconds") / w:.2f}' if w else "-"
    print(f'{key[0]} | {key[1] if key[1] >= 0 else "-"} | {med("wall_seconds"):.1f} | {med("cpu_seconds"):.1f} | '
          f'{med("peak_rss_mib"):.0f} | {med("scratch_peak_mib"):.0f} | {med("store_mib"):.1f} | {held} | {ratio}')
PY
