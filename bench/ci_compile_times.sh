#!/usr/bin/env bash
# Where CI's compile time goes: a clean clone of HEAD built as scripts/test-all.sh builds it (the release build, then
# the sanitizer build; no ccache, 2 jobs), every compile timed by bench/timed_compile.sh. Prints CPU seconds per
# group of objects (library, command line, tests, ...) and the wall time of each build.
# Usage: bench/ci_compile_times.sh SCRATCH_DIR      (needs about 3 GB there; tests are not run)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
scratch=${1:?usage: ci_compile_times.sh SCRATCH_DIR}
rm -rf "$scratch/clone"
mkdir -p "$scratch"
git clone -q "$repo" "$scratch/clone"
cd "$scratch/clone"
launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER="$repo/bench/timed_compile.sh" -DCMAKE_C_COMPILER_LAUNCHER="$repo/bench/timed_compile.sh")
summary() {  # log label
  awk -v label="$2" '{t = $1 + $2; o = $4; g = "library"
    if (o ~ /fuzz/) g = "fuzz replay"; else if (o ~ /bench\//) g = "benchmarks"; else if (o ~ /python/) g = "python module"
    else if (o ~ /tests\//) g = "tests"; else if (o ~ /ugvr_mpi\.dir/) g = "mpi front end"
    else if (o ~ /ugvr\.dir/) g = "command line"
    s[g] += t; n[g]++; total += t}
    END {for (g in s) printf "%s: %-14s %8.1f CPU s  %4d objects\n", label, g, s[g], n[g]
         printf "%s: %-14s %8.1f CPU s\n", label, "all", total}' "$1"
}
start=$SECONDS
export CCACHE_DISABLE=1 TIMED_COMPILE_LOG=$scratch/release.log
: >"$TIMED_COMPILE_LOG"
cmake -S . -B build -G Ninja -DUGVR_WERROR=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" -DUGVR_UNIT_TESTS=OFF "${launcher[@]}" >/dev/null
ninja -C build -j 2 >/dev/null
echo "release build: $((SECONDS - start)) s wall"
summary "$TIMED_COMPILE_LOG" release
start=$SECONDS
export TIMED_COMPILE_LOG=$scratch/asan.log
: >"$TIMED_COMPILE_LOG"
cmake -S . -B build-asan -G Ninja -DUGVR_WERROR=ON -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1" -DCMAKE_C_FLAGS_DEBUG="-O1" \
  -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang -DUGVR_SANITIZE=ON -DUGVR_BENCH=OFF "${launcher[@]}" >/dev/null
ninja -C build-asan -j 2 >/dev/null
echo "sanitizer build: $((SECONDS - start)) s wall"
summary "$TIMED_COMPILE_LOG" sanitizer
echo "per object: $scratch/release.log, $scratch/asan.log (user system wall object)"
