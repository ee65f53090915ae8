#!/usr/bin/env bash
# Peak RSS and wall time of `ugvr info CASE` (reading an OpenFOAM case whole: mesh, decomposition, one field), the
# median of RUNS runs each, measured with /usr/bin/time -v. Used for bench/README.md "OpenFOAM reading".
#
#   bash bench/run_openfoam_read.sh UGVR_BINARY CASE_DIR [CASE_DIR ...]     (RUNS=3 by default)
#
# Prints one line per case: binary, case, median max RSS (MiB), median elapsed (s), and every run's figures.
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,7p' "$0"; exit 2; }
ugvr=$1
shift
runs=${RUNS:-3}
command -v /usr/bin/time > /dev/null || { echo "needs /usr/bin/time (Debian package time)" >&2; exit 1; }
median() { sort -n | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }
for case_dir in "$@"; do
  rss=() secs=()
  for _ in $(seq "$runs"); do
    log=$(mktemp)
    /usr/bin/time -v "$ugvr" info "$case_dir" > /dev/null 2> "$log" || { cat "$log" >&2; rm -f "$log"; exit 1; }
    rss+=("$(awk -F': ' '/Maximum resident set size/ {printf "%.1f", $2 / 1024}' "$log")")
    secs+=("$(awk -F': ' '/Elapsed \(wall clock\)/ {n = split($2, t, ":"); s = 0; for (i = 1; i <= n; ++i) s = s * 60 + t[i]; print s}' "$log")")
    rm -f "$log"
  done
  printf '%s %s: peak RSS %s MiB, %s s (median of %d; runs: RSS %s MiB, time %s s)\n' "$ugvr" "$case_dir" \
    "$(printf '%s\n' "${rss[@]}" | median)" "$(printf '%s\n' "${secs[@]}" | median)" "$runs" "${rss[*]}" "${secs[*]}"
done
