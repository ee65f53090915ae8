#!/usr/bin/env bash
# README Quick start command 2 (and all that .ci/run does): install dependencies, build with warnings as errors,
# run every test; then build again with AddressSanitizer + UndefinedBehaviorSanitizer and run every test again.
# Tests on real data read ../shared/data (or $UGVR_DATA) and report themselves skipped when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/install-deps.sh

# The viewer's browser tests (tests/e2e) use playwright-core from npm, pinned by its package-lock.json.
if command -v npm >/dev/null && [ ! -d tests/e2e/node_modules/playwright-core ]; then
  npm ci --prefix tests/e2e --no-audit --no-fund
fi

jobs=$(nproc)
started=$SECONDS
phase() { echo "== $1 (at $((SECONDS - started)) s)"; }
run_suite() {  # build-dir, extra cmake args...
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DUGVR_WERROR=ON "$@" >/dev/null
  ninja -C "$dir" -j "$jobs"
  phase "$dir built"
  ctest --test-dir "$dir" --output-on-failure -j "$jobs"
}

# Compiling is most of this script's time on CI's 2 cores, and debug info a third of the compiling (measured:
# README.md, "How long the test command takes"): the release build has none (the same -O2 code: GCC's -g never
# changes it), the sanitizer build line tables only (-g1: file and line in its stack traces).
phase "release build + tests"
run_suite build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG"
phase "ASan + UBSan build + tests"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  run_suite build-asan -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g1 -O1" -DCMAKE_C_FLAGS_DEBUG="-g1 -O1" \
  -DUGVR_SANITIZE=ON -DUGVR_BENCH=OFF
phase "all passed"
