# The steps the step-switch scripts share (run_vtk_legacy_switch.sh, run_pvtu_switch.sh, run_openfoam_switch.sh):
# source it after setting `build` (BUILD_DIR), `rounds`, `before` (BEFORE, may be empty) and `alternations`.
#   time_switch_session SCRIPT      the session line (date, commit, cores, load) into bench/results/time_switch.jsonl
#   time_switch_runs INPUT ARGS...  bench_time_switch INPUT ARGS... --rounds $rounds from $build; with $before, each run
#                                   alternated with $before's bench_time_switch ($alternations pairs, before first),
#                                   lines tagged "build": before / after and the load then
time_switch_out=bench/results/time_switch.jsonl
mkdir -p bench/results

time_switch_session() {
  echo "{\"bench\":\"session\",\"script\":\"$1\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$(git rev-parse --short HEAD)\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$time_switch_out"
}

time_switch_runs() {
  if [ -z "$before" ]; then
    "$build/bench/bench_time_switch" "$@" --rounds "$rounds" | tee -a "$time_switch_out"
    return
  fi
  local which dir
  for _ in $(seq "$alternations"); do
    for which in before after; do
      dir=$build
      [ "$which" = before ] && dir=$before
      "$dir/bench/bench_time_switch" "$@" --rounds "$rounds" |
        sed "s/^{/{\"build\":\"$which\",\"load\":$(cut -d' ' -f1 /proc/loadavg),/" | tee -a "$time_switch_out"
    done
  done
}
