#!/usr/bin/env bash
# Stores with time (issue 18, docs/time-series.md "Stores with time"): one store holding every step of a generated
# 24-step series against 24 stores of one step each: bytes, build wall time, peak RSS (/usr/bin/time -v).
# Usage: bench/run_time_store.sh [UGVR=build/ugvr] [SCRATCH=/tmp/ugvr-time-store]
#   CELLS (default 2000000), STEPS (24), ROUNDS (default 1: builds of a 2M-cell series take minutes each; the medians
#   are over the rounds), BUILD_FLAGS (default "--max-depth 6": the build options of every store), RESULTS (default
#   bench/results/time_store.jsonl, appended), DELTA_BENCH (default: bench/bench_time_delta beside UGVR; skipped when
#   absent).
# Lines written: {"what": "series" ...} once, then per round {"what": "one_store", ...} and {"what":
# "separate_stores", ...} (the 24 builds summed: bytes, wall seconds; peak RSS the largest), then {"what": "summary"}
# with the medians and the ratios.
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=$(realpath "${1:-build/ugvr}")
scratch=${2:-/tmp/ugvr-time-store}
cells=${CELLS:-2000000}
steps=${STEPS:-24}
rounds=${ROUNDS:-1}
flags=${BUILD_FLAGS:---max-depth 6}
results=${RESULTS:-bench/results/time_store.jsonl}
delta_bench=${DELTA_BENCH:-$(dirname "$ugvr")/bench/bench_time_delta}
mkdir -p "$scratch" "$(dirname "$results")"

# Runs a command under /usr/bin/time -v; prints "WALL_SECONDS PEAK_RSS_BYTES".
timed() {
  local log="$scratch/time.log"
  /usr/bin/time -v "$@" >"$scratch/out.log" 2>"$log" || {
    cat "$scratch/out.log" "$log" >&2
    return 1
  }
  python3 - "$log" <<'PY'
import re, sys
t = open(sys.argv[1]).read()
wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t).group(1).split(":")
s = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1)) * 1024
print(s, rss)
PY
}

series="$scratch/wake.pvd"
if [ ! -f "$series" ]; then
  "$ugvr" --quiet generate --cells "$cells" --time-steps "$steps" -o "$series" >/dev/null
fi
series_bytes=$(du -cb "$scratch"/wake_*.vtu | tail -1 | cut -f1)
host=$(hostname)
date=$(date -u +%Y-%m-%dT%H:%M:%SZ)
echo "{\"what\": \"series\", \"date\": \"$date\", \"host\": \"$host\", \"cells\": $cells, \"steps\": $steps, \"vtu_bytes\": $series_bytes, \"build_flags\": \"$flags\"}" | tee -a "$results"

one_s=() one_b=() one_r=() sep_s=() sep_b=() sep_r=()
for ((r = 0; r < rounds; ++r)); do
  rm -f "$scratch/all.ugvr"
  # shellcheck disable=SC2086
  read -r s rss < <(timed "$ugvr" --quiet build "$series" --time all $flags -o "$scratch/all.ugvr")
  bytes=$(stat -c %s "$scratch/all.ugvr")
  one_s+=("$s") one_b+=("$bytes") one_r+=("$rss")
  echo "{\"what\": \"one_store\", \"round\": $r, \"seconds\": $s, \"bytes\": $bytes, \"peak_rss_bytes\": $rss}" | tee -a "$results"
  # Would temporal compression pay? The later steps' blocks against the same samples coded as differences from the
  # previous step (bench/bench_time_delta.cpp; 300 nodes spread over the tree), once.
  if [ "$r" = 0 ] && [ -x "$delta_bench" ]; then
    echo "{\"what\": \"temporal_delta\", \"measure\": $("$delta_bench" "$scratch/all.ugvr" 300 --json)}" | tee -a "$results"
  fi
  total_s=0 total_b=0 max_r=0
  for ((k = 0; k < steps; ++k)); do
    out="$scratch/step_$k.ugvr"
    rm -f "$out"
    # shellcheck disable=SC2086
    read -r s rss < <(timed "$ugvr" --quiet build "$series" --time-step "$k" $flags -o "$out")
    total_s=$(python3 -c "print($total_s + $s)")
    total_b=$((total_b + $(stat -c %s "$out")))
    [ "$rss" -gt "$max_r" ] && max_r=$rss
    rm -f "$out"
  done
  sep_s+=("$total_s") sep_b+=("$total_b") sep_r+=("$max_r")
  echo "{\"what\": \"separate_stores\", \"round\": $r, \"seconds\": $total_s, \"bytes\": $total_b, \"peak_rss_bytes\": $max_r}" | tee -a "$results"
done

python3 - "${one_s[*]}" "${one_b[*]}" "${one_r[*]}" "${sep_s[*]}" "${sep_b[*]}" "${sep_r[*]}" <<'PY' | tee -a "$results"
import json, statistics, sys
v = [[float(x) for x in a.split()] for a in sys.argv[1:]]
m = [statistics.median(x) for x in v]
print(json.dumps({"what": "summary", "rounds": len(v[0]),
                  "one_store": {"seconds": m[0], "bytes": int(m[1]), "peak_rss_bytes": int(m[2])},
                  "separate_stores": {"seconds": m[3], "bytes": int(m[4]), "peak_rss_bytes": int(m[5])},
                  "bytes_ratio": m[1] / m[4], "seconds_ratio": m[0] / m[3]}))
PY
