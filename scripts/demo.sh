#!/usr/bin/env bash
# README Quick start command 1: install dependencies, build, make the built-in demo dataset, describe it, render it
# with the exact engine, then open it in the interactive viewer (`ugvr view --demo`: open the URL it prints in a
# browser; Ctrl-C stops it). UGVR_DEMO_NO_VIEW=1 stops after the still image.
#   bash scripts/demo.sh time   the time-varying demo instead: a 24-step series of the same wing whose vortex street
#                               moves downstream (`ugvr generate --time-steps 24`), its animation rendered
#                               (out/wake/, a movie too when ffmpeg is installed), then playing in the viewer.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
ninja -C build ugvr
mkdir -p out
mode=${1:-}
# The demo's first view (the same as `ugvr view --demo` starts from, src/cli/demo_scene.h): the wing and its vortex
# street by pressure, from upstream, to the side and above; the free stream transparent over a dark background.
cat >out/demo-camera.json <<'JSON'
{"position": [-3.5, -9.5, 10.5], "focal_point": [4.0, 0.6, 0.4], "view_up": [0, 0, 1], "view_angle": 38}
JSON
cat >out/demo-tf.json <<'JSON'
[{"Name": "demo pressure", "ColorSpace": "RGB",
  "RGBPoints": [-1.8, 1.0, 1.0, 0.6, -0.6, 1.0, 0.8, 0.25, -0.3, 1.0, 0.45, 0.12, -0.1, 0.7, 0.12, 0.45,
                0.0, 0.2, 0.1, 0.4, 0.1, 0.1, 0.4, 0.8, 1.2, 0.6, 0.9, 1.0],
  "Points": [-1.8, 0.9, 0.5, 0.0, -0.3, 0.65, 0.5, 0.0, -0.12, 0.3, 0.5, 0.0, -0.05, 0.0, 0.5, 0.0,
             0.06, 0.0, 0.5, 0.0, 0.2, 0.3, 0.5, 0.0, 1.2, 0.8, 0.5, 0.0],
  "ScalarOpacityUnitDistance": 0.2}]
JSON
look=(--field pressure --camera out/demo-camera.json --tf out/demo-tf.json)
if [ "$mode" = time ]; then
  ./build/ugvr generate --cells 200000 --kind mixed --time-steps 24 -o out/wake.pvd
  ./build/ugvr info out/wake.pvd
  ./build/ugvr render out/wake.pvd "${look[@]}" --keep-range --background 0.02,0.02,0.04 --size 384 \
    --time all --out out/wake
  echo "demo: wrote out/wake/ (one image per step; movie.mp4 when ffmpeg is installed)"
  [ "${UGVR_DEMO_NO_VIEW:-0}" = 1 ] && exit 0
  echo "demo: starting the viewer, playing the series; open the URL below in a browser (Ctrl-C to stop)"
  exec ./build/ugvr view out/wake.pvd --fields pressure --camera out/demo-camera.json --tf out/demo-tf.json --play 10
fi
./build/ugvr generate --cells 200000 --kind mixed -o out/demo.vtu
./build/ugvr info out/demo.vtu
./build/ugvr render out/demo.vtu "${look[@]}" --keep-range \
  --background 0.02,0.02,0.04 --boundary-opacity 0.06 -o out/demo.png --stats out/demo-stats.json
echo "demo: wrote out/demo.png"
[ "${UGVR_DEMO_NO_VIEW:-0}" = 1 ] && exit 0
# The viewer: the first run builds the demo's brick store in the background (the page shows the exact engine's image
# and the build's progress meanwhile); later runs start from the store kept in ~/.cache/ugvr. Over SSH, forward the
# port: `ssh -L 8080:127.0.0.1:8080 host` and add `--port 8080`.
echo "demo: starting the viewer; open the URL below in a browser (Ctrl-C to stop)"
exec ./build/ugvr view --demo
