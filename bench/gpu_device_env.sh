# Sourced by bench/gpu_device_run.sh and bench/gpu_device_ab.sh on the bare GPU machine, from the repository root:
# unpacks the bundle of bench/make_gpu_bundle.sh into $g (default /tmp/g), points the loader, the shaders and the data
# at it, finds the NVIDIA EGL vendor file, and links the paths compiled into the tests (/work/main, /work/shared/data,
# build/ugvr for the golden-image test) to this checkout and the bundle. Sets root, g, out; sends the output to
# $out/log.txt as well.
root=$PWD
out=${OUT:?OUT names the folder whose files come back}
g=${g:-/tmp/g}
mkdir -p "$g" && tar -xJf "${BUNDLE:-.gpu/bundle.tar.xz}" -C "$g" || exit 1
export LD_LIBRARY_PATH=$g/lib UGVR_SHADER_DIR=$root/shaders UGVR_DATA=$g/data UGVR_COMMIT=$(cat "$g/commit")
# glvnd's libEGL looks for vendor files under /usr/share; the NVIDIA driver may keep its own elsewhere.
if ! ls /usr/share/glvnd/egl_vendor.d/*nvidia* >/dev/null 2>&1; then
  for f in /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json /etc/glvnd/egl_vendor.d/10_nvidia.json; do
    [ -f "$f" ] && export __EGL_VENDOR_LIBRARY_FILENAMES=$f && break
  done
fi
[ -e /work/main ] || { mkdir -p /work && ln -s "$root" /work/main; }
[ -e /work/shared/data ] || { mkdir -p /work/shared && ln -s "$g/data" /work/shared/data; }
[ -e build/ugvr ] || { mkdir -p build && ln -s "$g/bin/ugvr" build/ugvr; }
exec > >(tee "$out/log.txt") 2>&1
# The GL tests that run on the GPU (the default of TEST_FILTER).
gl_test_filter='ExactGpu.*:Hybrid.*:LodEngine.*:LodBoundary.*:LodTricubic.*:LodSlice.*:ExactSlice.*:LodAtlasBudget.*:LodPreintegration.*:LodOverlay.*:GoldenImages.*:GlProgram*:ConstantAndLinear/LodSeams.*:SliceContour*'
