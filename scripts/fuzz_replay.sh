#!/usr/bin/env bash
# The FuzzReplay test (tests/CMakeLists.txt): every fuzz target on its seeds (scripts/fuzz.sh SEEDS_ONLY=1, written
# into WORK) and the committed regression inputs of fuzz/regression/TARGET, each also mutated deterministically
# (fuzz/replay_main.cpp), in the build under test (release in CI, then ASan + UBSan). Fails on a crash, a sanitizer
# report, or a target without any input.
#   scripts/fuzz_replay.sh REPLAY_BINARY UGVR_BINARY WORK [MUTATIONS]
set -euo pipefail
cd "$(dirname "$0")/.."
replay=$1 ugvr=$2 work=$3 mutations=${4:-24}
rm -rf "$work"
FUZZ_CORPUS=$work SEEDS_ONLY=1 UGVR=$ugvr bash scripts/fuzz.sh >/dev/null
status=0
for src in fuzz/fuzz_*.cpp; do
  name=$(basename "$src" .cpp)
  inputs=()
  [ -d "$work/$name/seeds" ] && inputs+=("$work/$name/seeds")
  [ -d "fuzz/regression/$name" ] && inputs+=("fuzz/regression/$name")
  if [ ${#inputs[@]} -eq 0 ]; then
    echo "$name: no seeds and no regression inputs"
    status=1
    continue
  fi
  if ! "$replay" "$name" --mutate "$mutations" "${inputs[@]}"; then
    echo "$name: FAILED"
    status=1
  fi
done
exit $status
