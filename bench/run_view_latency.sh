#!/usr/bin/env bash
# `ugvr view` input-to-new-frame latency (issue 7): starts the viewer on a store, drives it with
# bench/view_latency.mjs (a 60 Hz dragging client, then single inputs after rest), appends one JSON line per run to
# bench/results/view_latency.jsonl after a `session` line.
# Usage: bench/run_view_latency.sh [SCRATCH=/tmp/ugvr-bench]
#   UGVR (default build/ugvr), UGVR_DATA (default ../shared/data), SIZE (800x600), FPS (10), RUN_SECONDS (15),
#   DATASETS (default "lox-post blunt-fin"), GPU (auto), TABS (1: clients dragging at once, each its own view;
#   one result line per client, with "tab" and "tabs"). Needs node >= 20.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
scratch=${1:-/tmp/ugvr-bench}
ugvr=${UGVR:-$root/build/ugvr}
data=${UGVR_DATA:-../shared/data}
size=${SIZE:-800x600}
fps=${FPS:-10}
seconds=${RUN_SECONDS:-15}
datasets=${DATASETS:-lox-post blunt-fin}
gpu=${GPU:-auto}
tabs=${TABS:-1}
jsonl=bench/results/view_latency.jsonl
mkdir -p "$scratch" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\",\"lp_num_threads\":\"${LP_NUM_THREADS:-}\"}" | tee -a "$jsonl"

for name in $datasets; do
  case $name in
    blunt-fin) field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") ;;
    lox-post) field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") ;;
    *) echo "unknown dataset $name" >&2; exit 1 ;;
  esac
  store="$scratch/$name-e0.01.ugvr"
  [ -f "$store" ] || "$ugvr" --quiet build "${inputs[@]}" --fields "$field" --error 0.01 -o "$store"
  log="$scratch/view.log"
  : >"$log"
  "$ugvr" view "$store" --port 0 --fps "$fps" --gpu "$gpu" >"$log" 2>&1 &
  pid=$!
  trap 'kill $pid 2>/dev/null || true' EXIT
  for _ in $(seq 100); do grep -q 'serving http' "$log" && break; sleep 0.1; done
  url=$(sed -n 's/.*serving \(http[^ ]*\).*/\1/p' "$log" | head -1)
  renderer=$(sed -n 's/.*serving http[^ ]* (\(.*\))$/\1/p' "$log" | head -1)
  [ -n "$url" ] || { cat "$log" >&2; exit 1; }
  ws=$(echo "$url" | sed 's|^http://\([^/]*\)/\(.*\)$|ws://\1/ws\2|')
  w=${size%x*} h=${size#*x}
  for t in $(seq "$tabs"); do
    node --experimental-websocket --no-warnings bench/view_latency.mjs "$ws" "$w" "$h" "$seconds" >"$scratch/tab$t.json" &
  done
  wait $(jobs -p | grep -v "^$pid\$") 2>/dev/null || true
  kill $pid
  wait $pid 2>/dev/null || true
  for t in $(seq "$tabs"); do
    /usr/bin/python3 -c "import json,sys; j=json.loads(open('$scratch/tab$t.json').read()); j.update(dataset='$name', fps_target=$fps, renderer='$renderer', tab=$t, tabs=$tabs); print(json.dumps(j, separators=(',', ':')))" <&- |
      tee -a "$jsonl"
  done
done
