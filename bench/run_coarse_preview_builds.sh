#!/usr/bin/env bash
# Out-of-core build time with and without the coarse preview (issue 24): RUNS alternating pairs of
#   ugvr build MESH --fields pressure --error 0.01 --max-depth 8 --out-of-core --memory MEMORY --json [--preview P]
# one JSON line per build ({"mode":"without"|"with","run":i,"load":L,"build":{...}}) on stdout.
# Usage: bench/run_coarse_preview_builds.sh MESH.vtu [SCRATCH=/tmp/ugvr-bench]; UGVR (default build/ugvr), MEMORY
# (default 1GiB), RUNS (default 3).
set -u
cd "$(dirname "$0")/.."
mesh=${1:?usage: run_coarse_preview_builds.sh MESH.vtu [SCRATCH]}
scratch=${2:-/tmp/ugvr-bench}
u=${UGVR:-$PWD/build/ugvr}
mkdir -p "$scratch"
for i in $(seq "${RUNS:-3}"); do
  for mode in without with; do
    extra=""
    [ $mode = with ] && extra="--preview $scratch/b-preview.ugvr"
    load=$(cut -d' ' -f1 /proc/loadavg)
    # shellcheck disable=SC2086
    j=$("$u" --quiet build "$mesh" -o "$scratch/b-$mode.ugvr" --fields pressure --error 0.01 --max-depth 8 \
      --out-of-core --memory "${MEMORY:-1GiB}" $extra --json)
    echo "{\"mode\":\"$mode\",\"run\":$i,\"load\":$load,\"build\":$j}"
  done
done
