#!/usr/bin/env bash
# The viewer's soak (issue 23): `ugvr view` on the oxygen post's store for SOAK_SECONDS (default 1800) with 4 clients
# dragging and 2 connecting and disconnecting (bench/view_soak.mjs), loopback only. The server's RSS is sampled
# every 10 s (/proc/PID/status VmRSS) into bench/results/view_soak.jsonl (one "sample" line each, then a "summary":
# RSS after warm-up (WARMUP, default 300 s) min / median / max and the max/min ratio, frames and connections);
# bench/plot_view_soak.py draws it (docs/img/view-soak.png).
# Usage: bench/run_view_soak.sh [SCRATCH=/tmp/ugvr-soak]
#   UGVR (build/ugvr), UGVR_DATA (../shared/data), SOAK_SECONDS (1800), WARMUP (300), SIZE (512), DRAGGERS (4),
#   CYCLERS (2), RAM (--ram-memory per tab, 256MiB). Needs node >= 20.
set -euo pipefail
cd "$(dirname "$0")/.."
scratch=${1:-/tmp/ugvr-soak}
ugvr=${UGVR:-build/ugvr}
data=${UGVR_DATA:-../shared/data}
seconds=${SOAK_SECONDS:-1800}
warmup=${WARMUP:-300}
size=${SIZE:-512}
draggers=${DRAGGERS:-4} cyclers=${CYCLERS:-2}
ram=${RAM:-256MiB}
jsonl=bench/results/view_soak.jsonl
mkdir -p "$scratch" bench/results
run="soak-$(date -u +%Y%m%dT%H%M%SZ)"
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
store=$scratch/lox-post.ugvr
[ -f "$store" ] || "$ugvr" --quiet build "$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin" \
  --fields StagnationEnergy --error 0.01 -o "$store"
log=$scratch/view.log
"$ugvr" view "$store" --port 0 --ram-memory "$ram" >"$log" 2>&1 &
pid=$!
trap 'kill $pid 2>/dev/null || true' EXIT
for _ in $(seq 300); do grep -q 'serving http' "$log" && break; sleep 0.1; done
url=$(sed -n 's/.*serving \(http[^ ]*\).*/\1/p' "$log" | head -1)
[ -n "$url" ] || { cat "$log" >&2; exit 1; }
ws=$(echo "$url" | sed 's|^http://\([^/]*\)/\(.*\)$|ws://\1/ws\2|')
node --experimental-websocket --no-warnings bench/view_soak.mjs "$ws" "$seconds" "$draggers" "$cyclers" "$size" \
  >"$scratch/clients.json" &
clients=$!
t0=$(date +%s)
samples=$scratch/samples.txt
: >"$samples"
while kill -0 "$clients" 2>/dev/null; do
  t=$(($(date +%s) - t0))
  rss=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status")
  echo "$t $rss" >>"$samples"
  echo "{\"bench\":\"view_soak\",\"run\":\"$run\",\"t\":$t,\"rss_kb\":$rss}" >>"$jsonl"
  sleep 10
done
wait "$clients" || echo "clients: the guard stopped them" >&2
# The server's RSS once every client has gone (the tabs' memory given back).
sleep 5
after=$(awk '/VmRSS/ {print $2}' "/proc/$pid/status")
kill $pid
wait $pid 2>/dev/null || true
/usr/bin/python3 - "$samples" "$warmup" "$scratch/clients.json" "$run" "$commit" "$after" "$seconds" "$size" \
  "$draggers" "$cyclers" "$ram" <<'PY' | tee -a "$jsonl"
import json, statistics, sys
samples, warmup, clients, run, commit, after, seconds, size, draggers, cyclers, ram = sys.argv[1:]
rows = [tuple(map(int, l.split())) for l in open(samples) if l.strip()]
warm = [r for t, r in rows if t >= int(warmup)]
c = json.loads(open(clients).read() or "{}")
out = {"bench": "view_soak", "run": run, "summary": True, "commit": commit, "seconds": int(seconds),
       "size": int(size), "draggers": int(draggers), "cyclers": int(cyclers), "ram_per_tab": ram,
       "samples": len(rows), "warmup_s": int(warmup), "clients": c, "rss_after_clients_kb": int(after)}
if warm:
    out.update(rss_min_kb=min(warm), rss_median_kb=int(statistics.median(warm)), rss_max_kb=max(warm),
               max_over_min=round(max(warm) / min(warm), 3))
print(json.dumps(out, separators=(",", ":")))
PY
