#!/usr/bin/env bash
# `ugvr build SERIES --time all` of two binaries, alternated (A B A B ...), on a generated .vtu series and an OpenFOAM
# case (issue 18 [time]: later steps read fields-only; bench/README.md "`ugvr build --time` reads later steps
# fields-only"). Each build under /usr/bin/time -v: wall, peak RSS, and the build's own read_seconds (--json), with
# the 1-minute load before it; the stores of the two binaries compared with cmp (same bytes expected: give THREADS=1,
# whose bricks are appended in one order; with more threads they may be appended in another order).
# Usage: bench/run_time_build_reads.sh UGVR_A UGVR_B [SCRATCH=/tmp/ugvr-time-build-reads]
#   CELLS (1000000), STEPS (8): the generated series (`ugvr generate --cells CELLS --time-steps STEPS`);
#   FOAM_N (100: N^3 hexahedra), FOAM_STEPS (8): the OpenFOAM case (bench/make_openfoam_case.py --binary --steps);
#   INPUTS ("wake foam"), ROUNDS (3), FLAGS (build options; default "--max-depth 5": --error 0.01, 32^3 bricks),
#   THREADS (empty: all), PYTHON (/usr/bin/python3: Debian's, with python3-numpy, for the OpenFOAM case), RESULTS (default
#   bench/results/time_build_reads.jsonl, appended).
# One JSON line per build, then per input a summary: the medians of each binary's wall, read seconds and peak RSS,
# and B/A.
set -euo pipefail
cd "$(dirname "$0")/.."
a=$(realpath "$1") b=$(realpath "$2")
scratch=${3:-/tmp/ugvr-time-build-reads}
cells=${CELLS:-1000000}
steps=${STEPS:-8}
foam_n=${FOAM_N:-100}
foam_steps=${FOAM_STEPS:-8}
inputs=${INPUTS:-wake foam}
rounds=${ROUNDS:-3}
flags=${FLAGS:---max-depth 5}
threads=${THREADS:-}
py=${PYTHON:-/usr/bin/python3}
results=${RESULTS:-bench/results/time_build_reads.jsonl}
mkdir -p "$scratch" "$(dirname "$results")"
[ -n "$threads" ] && flags="$flags --threads $threads"

for input in $inputs; do
  case $input in
    wake)
      series="$scratch/wake-$cells-$steps/wake.pvd"
      if [ ! -f "$series" ]; then
        mkdir -p "$(dirname "$series")"
        "$a" --quiet generate --cells "$cells" --time-steps "$steps" -o "$series" >/dev/null
      fi
      field_flags="--fields pressure" ;;
    foam)
      series="$scratch/foam-$foam_n-$foam_steps"
      [ -d "$series/constant" ] || "$py" bench/make_openfoam_case.py "$series" --n "$foam_n" --binary \
        --steps "$foam_steps"
      field_flags="--fields p" ;;
    *) echo "unknown input $input (wake, foam)" >&2; exit 2 ;;
  esac
  : >"$scratch/$input.lines"
  for ((r = 0; r < rounds; ++r)); do
    for bin in A B; do
      ugvr=$a
      [ "$bin" = B ] && ugvr=$b
      out="$scratch/$input-$bin.ugvr"
      rm -f "$out"
      load=$(cut -d' ' -f1 /proc/loadavg)
      # shellcheck disable=SC2086
      /usr/bin/time -v "$ugvr" --quiet build "$series" --time all $field_flags $flags --json -o "$out" \
        >"$scratch/out.json" 2>"$scratch/time.log" || { cat "$scratch/out.json" "$scratch/time.log" >&2; exit 1; }
      "$py" - "$scratch/out.json" "$scratch/time.log" "$input" "$bin" "$r" "$load" "$(stat -c %s "$out")" <<'PY' |
import json, re, sys
out, log, input_, bin_, r, load, size = sys.argv[1:]
text = open(out).read()
j = json.loads(text[text.index("{"):])
t = open(log).read()
wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t).group(1).split(":")
print(json.dumps({"what": "build", "input": input_, "binary": bin_, "round": int(r), "load": float(load),
                  "wall_seconds": sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall))),
                  "read_seconds": j["read_seconds"], "seconds": j["seconds"],
                  "peak_rss_bytes": int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1)) * 1024,
                  "store_bytes": int(size), "nodes": j["nodes"], "time_steps": j["time_steps"],
                  "step_reads_fields_only": j.get("step_reads_fields_only"), "step_reads_whole": j.get("step_reads_whole")}))
PY
        tee -a "$results" "$scratch/$input.lines"
    done
    if cmp -s "$scratch/$input-A.ugvr" "$scratch/$input-B.ugvr"; then same=true; else same=false; fi
    echo "{\"what\": \"same_store\", \"input\": \"$input\", \"round\": $r, \"same_bytes\": $same}" | tee -a "$results"
  done
  "$py" - "$scratch/$input.lines" "$input" "$a" "$b" <<'PY' | tee -a "$results"
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
def med(bin_, key):
    return statistics.median(x[key] for x in rows if x["binary"] == bin_)
s = {"what": "summary", "input": sys.argv[2], "A": sys.argv[3], "B": sys.argv[4], "rounds": len(rows) // 2,
     "load": [min(x["load"] for x in rows), max(x["load"] for x in rows)]}
for key in ("wall_seconds", "read_seconds", "peak_rss_bytes"):
    s[key] = {"A": med("A", key), "B": med("B", key), "B/A": med("B", key) / med("A", key)}
print(json.dumps(s))
PY
done
