#!/usr/bin/env bash
# README Quick start command 2 (and all that .ci/run does): install dependencies, build with warnings as errors and
# run the tests that need an optimised build (browser, Python, MPI); then build with AddressSanitizer +
# UndefinedBehaviorSanitizer and run the unit tests and the fuzz replay under them.
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

# Compiling is most of this script's time on CI's 2 cores (README.md, "How long the test command takes"), so nothing
# is compiled twice that need not be:
#  - the unit tests (ugvr_tests) and the fuzz replay are built and run once, in the sanitizer build; the release build
#    builds the library, the binary, the Python module and the MPI front end, and runs what needs them optimised: the
#    browser tests, the Python tests and notebook, the MPI tests, the public API's test;
#  - no debug information: the release build's code is the same without it (GCC's -g never changes it); the sanitizer
#    build's reports keep their function names (the symbol table) and UBSan's their file and line (compiled into each
#    check), and -g1 line tables were a fifth of its compile time; rerun a failing test in a -g build for lines;
#  - the sanitizer build is compiled by clang, about 0.7x GCC's time for the same -O1 + ASan + UBSan objects (GCC's
#    warnings still cover every library file through the release build). Not -O0 for the tests' own code (0.4x the
#    compile time, but the real-data tests' own loops ran 8-10x slower: 37 -> 370 s for one).
phase "release build + tests"
run_suite build -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" \
  -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG" -DUGVR_UNIT_TESTS=OFF
phase "ASan + UBSan build + tests"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  run_suite build-asan -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1" -DCMAKE_C_FLAGS_DEBUG="-O1" \
  -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_COMPILER=clang -DUGVR_SANITIZE=ON -DUGVR_BENCH=OFF
phase "all passed"
