#!/usr/bin/env bash
# The viewer on MPI (docs/mpi.md, "The viewer on a cluster"): `mpirun -np N ugvr view` of the oxygen post (102,675
# hexahedra, exact engine) at 512x512, one thread a rank, 1, 2 and 4 ranks in alternating rounds; one JSON line per
# run (bench/mpi_view_frames.py says what is measured) appended to bench/results/mpi_view.jsonl after a session line.
# Usage: bench/run_mpi_view.sh [UGVR]   (default build/ugvr); env: RANKS (default 1,2,4), ROUNDS (2), FRAMES (7),
#   SIZE (512), INPUT (default the post), UGVR_DATA (default /work/shared/data).
# Ranks beyond the cores are oversubscribed: on a 2-core machine 4 ranks share 2 cores (time slicing included).
set -euo pipefail
cd "$(dirname "$0")/.."
ugvr=${1:-build/ugvr}
data=${UGVR_DATA:-/work/shared/data}
input=${INPUT:-"$data/lox-post/postxyz.bin $data/lox-post/postq.bin"}
out=bench/results/mpi_view.jsonl
mkdir -p bench/results
printf '{"session": "%s", "commit": "%s", "nproc": %s, "load": "%s", "input": "%s"}\n' "$(date -u +%FT%TZ)" \
  "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)" "$input" >> "$out"
python3 bench/mpi_view_frames.py "$ugvr" "$input" --ranks "${RANKS:-1,2,4}" --rounds "${ROUNDS:-2}" \
  --frames "${FRAMES:-7}" --size "${SIZE:-512}" | tee -a "$out"
