#!/usr/bin/env bash
# Playback of a time series in `ugvr view` (issue 18): the viewer on a generated 24-step series (the demo wing's
# vortex street, `ugvr generate --time-steps 24`), the same series as one store with time (`store`: `ugvr build --time
# all`, the LOD engine plays it) and on mug.e (21 steps), driven by bench/view_playback.mjs with the
# step changing every frame at RATE steps a second; one JSON line per dataset to bench/results/view_playback.jsonl.
# The must-show: gap (frame-to-frame) p95 <= 1.5 x 1/RATE.
# Usage: bench/run_view_playback.sh [SCRATCH=/tmp/ugvr-playback]
#   UGVR (build/ugvr), UGVR_DATA (../shared/data), CELLS (generated series, 200000), SIZE (512), RATE (10),
#   RUN_SECONDS (30), DATASETS ("generated mug"; also "store"), LABEL (a tag in the result line), PACING ("shown": the
#   page's pacing by the frames' arrival; "asked": by the requests, as the page paced before 2026-11-27; see
#   bench/view_playback.mjs). Needs node >= 20.
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=${1:-/tmp/ugvr-playback}
ugvr=${UGVR:-build/ugvr}
data=${UGVR_DATA:-../shared/data}
cells=${CELLS:-200000} size=${SIZE:-512} rate=${RATE:-10} seconds=${RUN_SECONDS:-30} pacing=${PACING:-shown}
datasets=${DATASETS:-generated mug}
jsonl=bench/results/view_playback.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
for name in $datasets; do
  case $name in
    generated)
      input=$scratch/wake.pvd
      [ -f "$input" ] || "$ugvr" --quiet generate -o "$input" --cells "$cells" --time-steps 24 ;;
    store)
      [ -f "$scratch/wake.pvd" ] || "$ugvr" --quiet generate -o "$scratch/wake.pvd" --cells "$cells" --time-steps 24
      input=$scratch/wake.ugvr
      [ -f "$input" ] || "$ugvr" --quiet build "$scratch/wake.pvd" --time all -o "$input" ;;
    mug) input=$data/exodus-misc/mug.e ;;
    *) echo "unknown dataset $name" >&2; exit 1 ;;
  esac
  [ -e "$input" ] || { echo "skipped $name: $input is missing" >&2; continue; }
  log=$scratch/view.log
  # Where each frame's time goes (engine_host.cpp, UGVR_PLAYBACK_TRACE): summarised below as "breakdown" (a binary
  # without the trace writes none).
  trace=$scratch/trace-$name.jsonl
  rm -f "$trace"
  UGVR_PLAYBACK_TRACE=$trace "$ugvr" view "$input" --port 0 --fps "$rate" >"$log" 2>&1 &
  pid=$!
  trap 'kill $pid 2>/dev/null || true' EXIT
  for _ in $(seq 600); do grep -q 'serving http' "$log" && break; sleep 0.1; done
  url=$(sed -n 's/.*serving \(http[^ ]*\).*/\1/p' "$log" | head -1)
  [ -n "$url" ] || { cat "$log" >&2; exit 1; }
  renderer=$(sed -n 's/.*serving http[^ ]* (\(.*\))$/\1/p' "$log" | head -1)
  ws=$(echo "$url" | sed 's|^http://\([^/]*\)/\(.*\)$|ws://\1/ws\2|')
  node --experimental-websocket --no-warnings bench/view_playback.mjs "$ws" "$seconds" "$size" "$rate" "$pacing" \
    >"$scratch/out.json"
  kill $pid
  wait $pid 2>/dev/null || true
  /usr/bin/python3 - "$scratch/out.json" "$trace" <<EOF | tee -a "$jsonl"
import json, os, statistics, sys
j = json.loads(open(sys.argv[1]).read())
j.update(bench='view_playback', dataset='$name', label='${LABEL:-}', renderer='$renderer', commit='$commit',
         date='$(date -u +%FT%TZ)', load=$(cut -d' ' -f1 /proc/loadavg))
# The server's figures of the frames drawn while playing (medians, ms): the cut's update, the bricks' upload, the
# draw, the read-back, the encoding; the bricks the prefetch had ready at the switch, the cut before and after it.
if os.path.exists(sys.argv[2]):
    rows = [json.loads(l) for l in open(sys.argv[2]) if l.strip()]
    rows = [r for r in rows if r.get('playing')]
    def med(key, scale=1):
        xs = [r[key] * scale for r in rows if key in r]
        return round(statistics.median(xs), 2) if xs else None
    j['breakdown'] = dict(frames=len(rows), frame_ms=med('frame_seconds', 1e3), cut_ms=med('cut_seconds', 1e3),
                          upload_ms=med('load_seconds', 1e3), draw_ms=med('gpu_seconds', 1e3),
                          readback_ms=med('readback_seconds', 1e3), encode_ms=med('encode_seconds', 1e3),
                          uploads=med('uploads'), sync_reads=med('sync_reads'), prefetched=med('prefetched'),
                          cut_before_switch=med('switch_cut_before'), cut_after_switch=med('switch_cut_after'),
                          visible=med('visible_nodes'), scale=med('scale'), samples=med('samples'))
print(json.dumps(j, separators=(',', ':')))
EOF
done
