#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for FUZZ_SECONDS (default 60), seeded with the
# small real files of ../shared/data (or $UGVR_DATA) and the hand-made cases the targets add. Exits non-zero on the
# first crash; the reproducer is left in fuzz-corpus/<target>/crash-*.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-60}
data=${UGVR_DATA:-../shared/data}

cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DUGVR_FUZZ=ON -DUGVR_TESTS=OFF -DUGVR_BENCH=OFF >/dev/null
ninja -C build-fuzz

seed() {  # target, files...
  local dir=fuzz-corpus/$1/seeds
  shift
  mkdir -p "$dir"
  for f in "$@"; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 262144 ] && cp "$f" "$dir/"
  done
  return 0
}
seed fuzz_vtk_xml "$data"/vtk-small-ugrids/*.vtu
seed fuzz_vtk_legacy "$data"/vtk-small-ugrids/*.vtk "$data"/vtk-office/*.vtk

status=0
for bin in build-fuzz/fuzz/fuzz_*; do
  [ -x "$bin" ] || continue
  name=$(basename "$bin")
  mkdir -p "fuzz-corpus/$name/work" "fuzz-corpus/$name/seeds"
  echo "== $name: ${seconds}s"
  if ! (cd "fuzz-corpus/$name" && "../../$bin" -max_total_time="$seconds" -max_len=262144 -rss_limit_mb=4096 \
        -timeout=10 -print_final_stats=1 work seeds 2>&1 | tail -n 12); then
    echo "$name: FAILED"
    status=1
  fi
done
exit $status
