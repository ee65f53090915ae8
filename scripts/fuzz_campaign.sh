#!/usr/bin/env bash
# A fuzz campaign measured in CPU time: each libFuzzer target (ASan + UBSan, clang, build-fuzz/) runs in rounds of
# ROUND_SECONDS until its own CPU time (user + system, from /usr/bin/time) reaches CPU_MINUTES — wall time alone says
# little on a shared machine. The corpus grows across rounds (fuzz-corpus/TARGET/work, seeded by scripts/fuzz.sh).
# One JSON line per target goes to OUT (executions, CPU minutes, wall seconds, corpus units before/after, crashes);
# a crash stops that target and leaves its reproducer in fuzz-corpus/TARGET/crash-*.
#   CPU_MINUTES=10 JOBS=2 OUT=bench/results/fuzz_campaign.jsonl bash scripts/fuzz_campaign.sh [TARGET...]
# Without targets: every target in build-fuzz/fuzz. Run `bash scripts/fuzz.sh` once before (FUZZ_SECONDS=1 is enough)
# to build the targets and write the seeds.
set -euo pipefail
cd "$(dirname "$0")/.."
# Leaks inside the C libraries on a corrupt file (libcgns, libnetcdf, libhdf5: scripts/lsan.supp) are theirs, not
# findings: the sanitizer test run suppresses them the same way.
export LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}
cpu_minutes=${CPU_MINUTES:-10}
round=${ROUND_SECONDS:-180}
jobs=${JOBS:-2}
out=${OUT:-bench/results/fuzz_campaign.jsonl}
corpus=$(cd "${FUZZ_CORPUS:-fuzz-corpus}" && pwd)
mkdir -p "$(dirname "$out")"
out=$(cd "$(dirname "$out")" && pwd)/$(basename "$out")

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for bin in build-fuzz/fuzz/fuzz_*; do [ -x "$bin" ] && targets+=("$(basename "$bin")"); done
fi

campaign() {  # target
  local name=$1 bin dir execs=0 cpu=0 wall0 crashes=0 before after log
  bin=$(pwd)/build-fuzz/fuzz/$name
  dir=$corpus/$name
  local extra=()  # the committed regression inputs seed the campaign too
  [ -d "fuzz/regression/$name" ] && extra+=("$(pwd)/fuzz/regression/$name")
  mkdir -p "$dir/work" "$dir/seeds"
  before=$(find "$dir/work" -type f | wc -l)
  wall0=$(date +%s)
  log=$dir/campaign.log
  : >"$log"
  # CPU time in centiseconds keeps the loop in integer arithmetic.
  while [ "$cpu" -lt $((cpu_minutes * 6000)) ]; do
    local times rc=0
    times=$(mktemp)
    (cd "$dir" && /usr/bin/time -f "%U %S" -o "$times" "$bin" -max_total_time="$round" -max_len=262144 \
      -rss_limit_mb=4096 -timeout=10 -print_final_stats=1 work seeds "${extra[@]}" >>"$log" 2>&1) || rc=$?
    # The last line: /usr/bin/time puts "Command exited with non-zero status N" before it when the fuzzer fails.
    read -r user sys < <(tail -n 1 "$times") || true
    rm -f "$times"
    cpu=$((cpu + $(printf '%.0f' "$(echo "($user + $sys) * 100" | bc)")))
    execs=$((execs + $(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | tail -n 1 | grep -o '[0-9]*$' || echo 0)))
    if [ "$rc" -ne 0 ]; then
      crashes=$(find "$dir" -maxdepth 1 \( -name 'crash-*' -o -name 'timeout-*' -o -name 'oom-*' -o -name 'leak-*' \) | wc -l)
      echo "$name: the fuzzer stopped with status $rc (see $log)" >&2
      break
    fi
  done
  after=$(find "$dir/work" -type f | wc -l)
  printf '{"target":"%s","executions":%d,"cpu_minutes":%.2f,"wall_seconds":%d,"corpus_before":%d,"corpus_after":%d,"findings":%d,"commit":"%s","date":"%s"}\n' \
    "$name" "$execs" "$(echo "$cpu / 6000" | bc -l)" $(($(date +%s) - wall0)) "$before" "$after" "$crashes" \
    "$(git rev-parse --short HEAD)" "$(date -u +%FT%TZ)" | tee -a "$out"
}

running=0
for t in "${targets[@]}"; do
  campaign "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$jobs" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait
