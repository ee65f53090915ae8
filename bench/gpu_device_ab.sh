#!/usr/bin/env bash
# A second kind of device call: build A against build B on the same warm GPU, plus the first-frame shader compile
# times and the GL tests. A is an older `ugvr` with its shaders, packed as
#   strip -o .gpu/a/ugvr OLD/build/ugvr; git archive OLD_COMMIT shaders | tar -x -C .gpu/a; echo OLD_COMMIT >.gpu/a/commit
#   tar -cJf .gpu/ugvr-a.tar.xz -C .gpu/a .
# B is the bundle of bench/make_gpu_bundle.sh (this checkout's build and shaders/). Both load the bundle's libraries.
# Parts (PARTS, in order, default "hybrid compile tests"), each bounded:
#   hybrid:  bench/run_hybrid.sh with B (the stores, the exact references, B's figures), then
#            bench/run_hybrid_ab.sh A B alternated ROUNDS times (SIZE, FRAMES; the GPU timer is the figure);
#   compile: bench/shader_compile_times.sh for B's shaders and for copies with `#pragma optionNV(unroll none)` and
#            `#pragma optionNV(inline none)` after #version (the NVIDIA compiler's options), cache off, then B's
#            shaders with the cache on twice (cold, warm);
#   tests:   the GL tests of gpu_device_run.sh on this GPU (after the other parts warmed the driver's shader cache).
# Usage, from the repository root on the GPU machine: OUT=... bash bench/gpu_device_ab.sh. Results in OUT:
# log.txt, hybrid.jsonl, hybrid_ab.txt, hybrid-ab.jsonl, compile.jsonl, tests.txt, ab.tgz (B's pictures).
set -u
a=/tmp/a
mkdir -p "$a" && tar -xJf "${BUNDLE_A:-.gpu/ugvr-a.tar.xz}" -C "$a" || exit 1
source bench/gpu_device_env.sh
unset UGVR_SHADER_DIR  # each build is given its own below
echo "A $(cat "$a/commit"), B $(cat "$g/commit"); $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -1)"
size=${SIZE:-1024}

for part in ${PARTS:-hybrid compile tests}; do
  start=$SECONDS
  case $part in
    hybrid)
      UGVR=$g/bin/ugvr UGVR_SHADER_DIR=$root/shaders SIZE=$size FRAMES=${FRAMES:-5} timeout "${HYBRID_SECONDS:-90}" \
        bash bench/run_hybrid.sh gpu-b /tmp/h/b /tmp/h
      SHADERS_A=$a/shaders SHADERS_B=$root/shaders SIZE=$size ROUNDS=${ROUNDS:-3} FRAMES=${FRAMES:-5} \
        timeout "${AB_SECONDS:-150}" bash bench/run_hybrid_ab.sh "$a/ugvr" "$g/bin/ugvr" /tmp/h >"$out/hybrid_ab.txt" 2>&1
      cat "$out/hybrid_ab.txt"
      grep '"bench": "hybrid"' bench/results/hybrid.jsonl >"$out/hybrid.jsonl"
      cp /tmp/h/hybrid-ab.jsonl "$out/" 2>/dev/null
      tar -czf "$out/ab.tgz" -C /tmp/h b ;;
    compile)
      dirs=("$root/shaders")
      for v in "unroll none" "inline none"; do
        d=/tmp/shaders-${v// /-}
        cp -r "$root/shaders" "$d" && sed -i "/^#version/a #pragma optionNV($v)" "$d"/*.comp && dirs+=("$d")
      done
      { CACHE=off UGVR=$g/bin/ugvr timeout "${COMPILE_SECONDS:-150}" bash bench/shader_compile_times.sh /tmp/sct "${dirs[@]}"
        CACHE="on on" UGVR=$g/bin/ugvr timeout 60 bash bench/shader_compile_times.sh /tmp/sct; } >"$out/compile.jsonl"
      cat "$out/compile.jsonl" ;;
    tests)
      filter=${TEST_FILTER:-$gl_test_filter}
      UGVR_SHADER_DIR=$root/shaders timeout "${TESTS_SECONDS:-120}" "$g/bin/ugvr_tests" --gtest_filter="$filter" \
        >"$out/tests.txt" 2>&1
      echo "tests: exit $? ($(grep -c '^\[       OK' "$out/tests.txt") OK, $(grep -c '^\[  FAILED' "$out/tests.txt") FAILED lines)"
      grep -E '^\[  FAILED|^\[  SKIPPED' "$out/tests.txt" | sort -u | head -40 ;;
  esac
  echo "== part $part: $((SECONDS - start)) s"
done
