#!/usr/bin/env bash
# Compiler launcher for bench/ci_compile_times.sh: runs one compile and appends "user system wall object" (seconds)
# to $TIMED_COMPILE_LOG. CPU seconds, unlike wall time, hardly depend on what else the machine runs.
obj=unknown
prev=
for a in "$@"; do
  [ "$prev" = "-o" ] && obj=$a
  prev=$a
done
tf=$(mktemp)
/usr/bin/time -f "%U %S %e" -o "$tf" "$@"
rc=$?
echo "$(tail -1 "$tf") $obj" >>"${TIMED_COMPILE_LOG:?set TIMED_COMPILE_LOG}"
rm -f "$tf"
exit $rc
