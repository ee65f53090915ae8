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
# PLOT3D: the real files are too large as seeds; make small ones in the target's input layout (uint32 grid length,
# grid file, Q file) for big- and little-endian, C and Fortran layouts, with and without IBLANK.
/usr/bin/python3 - fuzz-corpus/fuzz_plot3d/seeds <<'PY'
import os, struct, sys
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
dims = (3, 2, 2)
n = dims[0] * dims[1] * dims[2]
for endian in "<>":
    for fortran in (False, True):
        for iblank in (False, True):
            def rec(payload):
                return struct.pack(endian + "i", len(payload)) + payload + struct.pack(endian + "i", len(payload)) if fortran else payload
            xyz = struct.pack(endian + "%df" % (3 * n), *[float(i % 7) + 0.5 * (i // n) for i in range(3 * n)])
            if iblank:
                xyz += struct.pack(endian + "%di" % n, *[1 if i % 5 else 0 for i in range(n)])
            grid = rec(struct.pack(endian + "3i", *dims)) + rec(xyz)
            q = rec(struct.pack(endian + "3i", *dims)) + rec(struct.pack(endian + "4f", 0.5, 0.0, 1e3, 1.0))
            q += rec(struct.pack(endian + "%df" % (5 * n), *[1.0 + 0.01 * i for i in range(5 * n)]))
            name = "p3d_%s_%s_%s" % ("be" if endian == ">" else "le", "fortran" if fortran else "c", "iblank" if iblank else "plain")
            with open(os.path.join(out, name), "wb") as f:
                f.write(struct.pack("<I", len(grid)) + grid + q)
PY

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
