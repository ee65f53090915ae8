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
run_suite() {  # build-dir, extra cmake args...
  local dir=$1
  shift
  cmake -S . -B "$dir" -G Ninja -DUGVR_WERROR=ON "$@" >/dev/null
  ninja -C "$dir" -j "$jobs"
  ctest --test-dir "$dir" --output-on-failure -j "$jobs"
}

echo "== release build + tests"
run_suite build -DCMAKE_BUILD_TYPE=RelWithDebInfo
echo "== ASan + UBSan build + tests"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  run_suite build-asan -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-g -O1" -DUGVR_SANITIZE=ON -DUGVR_BENCH=OFF
