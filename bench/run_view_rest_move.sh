#!/usr/bin/env bash
# A move during a resting frame (bench/view_rest_move.mjs): `ugvr view` of a store with cells (the hybrid engine's
# exact batches at rest: seconds a frame on llvmpipe), binaries A and B alternated ROUNDS times in one run; one JSON
# line per run appended to bench/results/view_rest_move.jsonl after a `session` line.
# Usage: bench/run_view_rest_move.sh A_UGVR B_UGVR [SCRATCH=/tmp/ugvr-rest-move]
#   UGVR_DATA (../shared/data), DATASET (blunt-fin | lox-post), SIZE (512x512), MOVES (8), DELAY_MS (100; 700 with
#   MPI), ROUNDS (2). Needs node >= 20. The store is built once, with A, `--cells` (kept in SCRATCH).
#   MPI=N: `mpirun --oversubscribe -np N UGVR view MESH --threads THREADS (1)` instead: the mesh itself, every rank
#   its part with the exact engine, no store. The resting frame is then one collective frame, drawn whole unless cut
#   short, and the second move goes DELAY_MS after the first move's moving frame was shown (past the 0.5 s rest delay
#   of a viewer whose MPI frames cannot be cut short, so that the resting frame is under way with either binary).
set -euo pipefail
cd "$(dirname "$0")/.."
a=$1 b=$2
scratch=${3:-/tmp/ugvr-rest-move}
data=${UGVR_DATA:-../shared/data}
dataset=${DATASET:-blunt-fin}
size=${SIZE:-512x512}
moves=${MOVES:-8}
mpi=${MPI:-0}
threads=${THREADS:-1}
if [ "$mpi" -gt 0 ]; then delay=${DELAY_MS:-700} wait_for=moving; else delay=${DELAY_MS:-100} wait_for=rest; fi
rounds=${ROUNDS:-2}
jsonl=bench/results/view_rest_move.jsonl
mkdir -p "$scratch" bench/results
case $dataset in
  blunt-fin) field=Density inputs=("$data/blunt-fin/bluntfinxyz.bin" "$data/blunt-fin/bluntfinq.bin") ;;
  lox-post) field=StagnationEnergy inputs=("$data/lox-post/postxyz.bin" "$data/lox-post/postq.bin") ;;
  *) echo "unknown dataset $dataset" >&2; exit 1 ;;
esac
if [ "$mpi" -gt 0 ]; then
  view_input=("${inputs[@]}" --threads "$threads")  # the mesh's first field, as the page starts
  launcher=(mpirun --oversubscribe -np "$mpi")
else
  store="$scratch/$dataset-cells.ugvr"
  [ -f "$store" ] || "$a" --quiet build "${inputs[@]}" --fields "$field" --cells -o "$store"
  view_input=("$store")
  launcher=()
fi
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\",\"a\":\"$a\",\"b\":\"$b\"}" | tee -a "$jsonl"
w=${size%x*} h=${size#*x}
for round in $(seq "$rounds"); do
  for label in A B; do
    bin=$a
    [ "$label" = B ] && bin=$b
    log="$scratch/view.log"
    : >"$log"
    "${launcher[@]}" "$bin" view "${view_input[@]}" --port 0 --fps 10 --size "$size" >"$log" 2>&1 &
    pid=$!
    trap 'kill $pid 2>/dev/null || true' EXIT
    for _ in $(seq 300); do grep -q 'serving http' "$log" && break; sleep 0.1; done
    url=$(sed -n 's/.*serving \(http[^ ]*\).*/\1/p' "$log" | head -1)
    [ -n "$url" ] || { cat "$log" >&2; exit 1; }
    ws=$(echo "$url" | sed 's|^http://\([^/]*\)/\(.*\)$|ws://\1/ws\2|')
    out=$(node --experimental-websocket --no-warnings bench/view_rest_move.mjs "$ws" "$w" "$h" "$moves" "$delay" "$wait_for")
    kill $pid
    wait $pid 2>/dev/null || true
    /usr/bin/python3 -c "import json,sys; j=json.loads(sys.argv[1]); j.update(label='$label', round=$round, dataset='$dataset', mpi_ranks=$mpi, load=float(open('/proc/loadavg').read().split()[0])); print(json.dumps(j, separators=(',', ':')))" "$out" |
      tee -a "$jsonl"
  done
done
