#!/usr/bin/env bash
# What the leaves' cells cost the out-of-core build (the [hybrid] issue 17; docs/octree-build.md "Cells per leaf"):
# `ugvr build X.vtu --out-of-core --memory M [--cells]` on generated tetrahedral meshes (`ugvr generate --kind tet`,
# pressure, --error 0.01, --max-depth 8), without and with --cells, REPS times each (alternating): wall time, peak RSS
# (/usr/bin/time -v), store size, the cell blocks' bytes and cells; then the medians per (N, cells) as a Markdown
# table. One JSON line per run is appended to bench/results/ooc_cells.jsonl after a `session` line.
# Usage: bench/run_ooc_cells.sh [SCRATCH=/tmp/ugvr-ooc-cells]
#   UGVR (default build/ugvr), SIZES ("1000000 10000000"), REPS ("3 2": per size, in order), MEMORY (256MiB),
#   THREADS (0: all cores). Needs about 4.5 GB of scratch for 10M (the .vtu, the soup and the pending node files).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
scratch=${1:-/tmp/ugvr-ooc-cells}
ugvr=${UGVR:-$root/build/ugvr}
sizes=(${SIZES:-1000000 10000000})
reps=(${REPS:-3 2})
memory=${MEMORY:-256MiB}
threads=${THREADS:-0}
out=bench/results/ooc_cells.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"memory\":\"$memory\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" |
  tee -a "$out"
session_start=$(wc -l <"$out")

for i in "${!sizes[@]}"; do
  n=${sizes[$i]}
  r=${reps[$i]:-${reps[-1]}}
  vtu="$scratch/tet-$n.vtu"
  [ -f "$vtu" ] || "$ugvr" --quiet generate --cells "$n" --kind tet -o "$vtu" >/dev/null
  for ((k = 0; k < r; ++k)); do
    for cells in 0 1; do
      flag=()
      [ "$cells" = 1 ] && flag=(--cells)
      f="$scratch/tet-$n.ugvr"
      /usr/bin/time -v "$ugvr" --quiet build "$vtu" -o "$f" --fields pressure --error 0.01 --max-depth 8 \
        --out-of-core --memory "$memory" --threads "$threads" --json "${flag[@]}" >"$scratch/build.out" \
        2>"$scratch/build.time"
      rss_kb=$(awk -F': ' '/Maximum resident set size/ {print $2}' "$scratch/build.time")
      echo "{\"bench\":\"ooc_cells\",\"n\":$n,\"cells\":$cells,\"memory\":\"$memory\",\"time_peak_rss_bytes\":$((rss_kb * 1024)),\"summary\":$(cat "$scratch/build.out")}" |
        tee -a "$out" | cut -c1-200
      rm -f "$f"
    done
  done
done

# Medians of this session's runs.
tail -n +"$((session_start + 1))" "$out" | python3 -c "$(
  cat <<'PY'
import json, statistics, sys
runs = [json.loads(l) for l in sys.stdin if l.strip()]
runs = [r for r in runs if r.get("bench") == "ooc_cells"]
print("| tets | --cells | runs | wall (median) | peak RSS (median) | store | cell blocks | cells kept | leaves in pieces |")
print("|---|---|---|---|---|---|---|---|---|")
for n, c in sorted({(r["summary"]["cells"], r["cells"]) for r in runs}):
    g = [r for r in runs if r["summary"]["cells"] == n and r["cells"] == c]
    s = g[0]["summary"]
    wall = statistics.median(r["summary"]["seconds"] for r in g)
    rss = statistics.median(r["time_peak_rss_bytes"] for r in g) / 2**20
    print(f"| {n:,} | {'yes' if c else 'no'} | {len(g)} | {wall:.1f} s | {rss:.0f} MiB | {s['store_bytes']:,} B | "
          f"{s['cell_bytes']:,} B | {s['leaf_cells']:,} | {s['leaves_in_pieces']} |")
PY
)"
