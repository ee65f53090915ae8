#!/usr/bin/env bash
# What one call of the GPU machine runs (the machine is bare and lent for minutes): unpacks the bundle of
# bench/make_gpu_bundle.sh, runs the GL tests on the GPU, then bench/run_gpu.sh's SECTIONS, each bounded so that the
# results written so far always come back. Everything lands in OUT (the device tool's $OUT): log.txt, gpu.jsonl,
# tests.txt and results.tgz (the images and per-section files).
# Usage, from the repository root on the GPU machine: bash bench/gpu_device_run.sh
#   BUNDLE (.gpu/bundle.tar.xz), OUT ($OUT), SECTIONS (default "lost-rays hybrid exact-gpu slices tricubic view lod"),
#   TESTS_SECONDS (150), BENCH_SECONDS (330), SIZE (1024), TEST_FILTER (the GL tests).
# The set-up (bundle, loader, EGL vendor, the paths compiled into the tests) is bench/gpu_device_env.sh.
set -u
source bench/gpu_device_env.sh
echo "commit $UGVR_COMMIT; $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | head -1)"

filter=${TEST_FILTER:-$gl_test_filter}
echo "== GL tests on this GPU ($filter)"
timeout "${TESTS_SECONDS:-150}" "$g/bin/ugvr_tests" --gtest_filter="$filter" >"$out/tests.txt" 2>&1
echo "tests: exit $? ($(grep -c '^\[       OK' "$out/tests.txt") OK, $(grep -c '^\[  FAILED' "$out/tests.txt") FAILED lines, $(grep -c '^\[  SKIPPED' "$out/tests.txt") skipped)"
grep -E '^\[  FAILED|^\[  SKIPPED' "$out/tests.txt" | sort -u | head -40

r=/tmp/r
mkdir -p "$r"
UGVR=$g/bin/ugvr SEAMS=$g/bin/bench_lod_seams SIZE=${SIZE:-1024} SKIP_BIG=1 \
  SECTIONS=${SECTIONS:-lost-rays hybrid exact-gpu slices tricubic view lod} timeout "${BENCH_SECONDS:-330}" \
  bash bench/run_gpu.sh "$r" /tmp/s
echo "run_gpu: exit $?"
cp "$r/gpu.jsonl" "$out/gpu.jsonl" 2>/dev/null
cp bench/results/*.jsonl "$r/" 2>/dev/null
tar -czf "$out/results.tgz" -C "$r" --exclude='*.pfm' . && ls -la "$out"
