#!/usr/bin/env bash
# Packs what a bare GPU machine needs to run this build's GPU checks (bench/run_gpu.sh, the GL tests): the stripped
# `ugvr`, `ugvr_tests` and `bench_lod_seams`, every shared library they load except glibc's own (the GPU machine's
# image has none of the project's libraries), glvnd's GL/EGL loaders (the NVIDIA driver brings only its vendor
# library), and the two PLOT3D datasets of the benchmarks. The machine's Python runs the bench scripts' helpers.
# Usage: bench/make_gpu_bundle.sh [BUILD=build] [OUT=.gpu/bundle.tar.xz]
# On the GPU machine, from the repository root:
#   mkdir -p /tmp/g && tar -xJf .gpu/bundle.tar.xz -C /tmp/g
#   export LD_LIBRARY_PATH=/tmp/g/lib UGVR_SHADER_DIR=$PWD/shaders UGVR_DATA=/tmp/g/data
#   UGVR=/tmp/g/bin/ugvr SEAMS=/tmp/g/bin/bench_lod_seams bash bench/run_gpu.sh OUT SCRATCH
# (.gpu/ is ignored through .git/info/exclude; bench/gpu_device_run.sh is the script one device call runs.)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
out=${2:-.gpu/bundle.tar.xz}
data=${UGVR_DATA:-../shared/data}
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/bin" "$stage/lib" "$stage/data" "$(dirname "$out")"
bins=("$build/ugvr" "$build/tests/ugvr_tests" "$build/bench/bench_lod_seams")
for b in "${bins[@]}"; do
  [ -x "$b" ] || { echo "make_gpu_bundle: $b is not built (cmake --build $build)" >&2; exit 1; }
  strip -o "$stage/bin/$(basename "$b")" "$b"
done
# glibc's libraries stay behind: the machine's own (newer) glibc must load them together.
glibc='^(linux-vdso|libc|libm|libpthread|libdl|librt|libresolv|ld-linux-x86-64)\.so'
for b in "${bins[@]}"; do ldd "$b"; done | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u |
  while read -r name path; do
    [[ $name =~ $glibc ]] && continue
    cp -L "$path" "$stage/lib/$name"
  done
for gl in libEGL.so.1 libGL.so.1 libOpenGL.so.0 libGLdispatch.so.0 libGLX.so.0; do
  cp -L "/usr/lib/x86_64-linux-gnu/$gl" "$stage/lib/$gl"
done
for d in blunt-fin lox-post; do
  [ -d "$data/$d" ] && cp -r "$data/$d" "$stage/data/"
done
git rev-parse --short HEAD >"$stage/commit" 2>/dev/null || echo unknown >"$stage/commit"
tar -cJf "$out.tmp" -C "$stage" . && mv "$out.tmp" "$out"
echo "make_gpu_bundle: $out ($(du -h "$out" | cut -f1), $(ls "$stage/lib" | wc -l) libraries, commit $(cat "$stage/commit"))"
