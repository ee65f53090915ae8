#!/usr/bin/env bash
# README Quick start command 1: install dependencies, build, make the built-in demo dataset, describe it, render it
# with the exact engine, then open it in the interactive viewer (`ugvr view --demo`: open the URL it prints in a
# browser; Ctrl-C stops it). UGVR_DEMO_NO_VIEW=1 stops after the still image.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
ninja -C build ugvr
mkdir -p out
./build/ugvr generate --cells 200000 --kind mixed -o out/demo.vtu
./build/ugvr info out/demo.vtu
# A view of the wing from above and behind, and a transfer function that shows its wake (slow air opaque and bright,
# the free stream transparent).
cat >out/demo-camera.json <<'JSON'
{"position": [7.5, -9.0, 7.0], "focal_point": [0.5, 0.0, 0.6], "view_up": [0, 0, 1], "view_angle": 30}
JSON
cat >out/demo-tf.json <<'JSON'
[{"Name": "demo wake", "ColorSpace": "RGB",
  "RGBPoints": [0.0, 0.98, 0.9, 0.15, 0.5, 0.9, 0.35, 0.1, 0.95, 0.35, 0.05, 0.45, 1.6, 0.05, 0.05, 0.25],
  "Points": [0.0, 0.9, 0.5, 0.0, 0.6, 0.5, 0.5, 0.0, 0.97, 0.02, 0.5, 0.0, 1.6, 0.0, 0.5, 0.0],
  "ScalarOpacityUnitDistance": 0.3}]
JSON
./build/ugvr render out/demo.vtu --field velocity --camera out/demo-camera.json --tf out/demo-tf.json --keep-range \
  --boundary-opacity 0.1 -o out/demo.png --stats out/demo-stats.json
echo "demo: wrote out/demo.png"
[ "${UGVR_DEMO_NO_VIEW:-0}" = 1 ] && exit 0
# The viewer: the first run builds the demo's brick store in the background (the page shows the exact engine's image
# and the build's progress meanwhile); later runs start from the store kept in ~/.cache/ugvr. Over SSH, forward the
# port: `ssh -L 8080:127.0.0.1:8080 host` and add `--port 8080`.
echo "demo: starting the viewer; open the URL below in a browser (Ctrl-C to stop)"
exec ./build/ugvr view --demo --camera out/demo-camera.json --tf out/demo-tf.json
