#!/usr/bin/env bash
# End-to-end tests of the `ugvr view` browser viewer in headless Chromium (ctest ViewerE2E, tests/CMakeLists.txt).
# Usage: run.sh UGVR_BINARY
# Builds a small store in a temporary directory, installs playwright-core (package-lock.json) when node_modules is
# missing, then runs viewer.test.mjs, controls.test.mjs, slices.test.mjs, engine.test.mjs, time.test.mjs, time_store.test.mjs, pieces.test.mjs and hybrid.test.mjs, each of which starts `ugvr view` itself. Exit 77 (ctest: skipped) only when node or
# Chromium is absent; any other problem fails.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
ugvr=${1:?usage: run.sh UGVR_BINARY}
export UGVR_CHROMIUM=${UGVR_CHROMIUM:-/usr/bin/chromium}

if ! command -v node >/dev/null; then
  echo "SKIP: node is not installed"
  exit 77
fi
if [ ! -x "$UGVR_CHROMIUM" ]; then
  echo "SKIP: no Chromium at $UGVR_CHROMIUM (apt-get install chromium, or set UGVR_CHROMIUM)"
  exit 77
fi
if [ ! -d "$here/node_modules/playwright-core" ]; then
  npm ci --prefix "$here" --no-audit --no-fund
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/ugvr-e2e.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
"$ugvr" --quiet generate --cells 20000 --kind mixed -o "$tmp/mixed.vtu" >/dev/null
"$ugvr" --quiet generate --cells 20000 --time-steps 4 -o "$tmp/wake.pvd" >/dev/null
"$ugvr" --quiet build "$tmp/mixed.vtu" -o "$tmp/mixed.ugvr" --fields pressure,velocity --brick 8 --max-depth 4 >/dev/null
"$ugvr" --quiet build "$tmp/mixed.vtu" -o "$tmp/mixed-cells.ugvr" --fields pressure,velocity --brick 8 --max-depth 3 --cells >/dev/null
"$ugvr" --quiet build "$tmp/mixed.vtu" -o "$tmp/pieces.json" --fields pressure,velocity --brick 8 --max-depth 4 --pieces 2 >/dev/null
"$ugvr" --quiet build "$tmp/wake.pvd" -o "$tmp/wake.ugvr" --time all --fields pressure --brick 8 --max-depth 4 >/dev/null
# Run in this process (not under `node --test`, which runs the file in a child) and stopped before ctest's TIMEOUT, so
# that the signal reaches node, which then stops `ugvr view` and Chromium.
UGVR="$ugvr" UGVR_STORE="$tmp/mixed.ugvr" timeout -k 5 300 node --test-reporter=spec "$here/viewer.test.mjs"
# The page's controls (TF editor, field picker, clip, files, ...), against a viewer of their own.
UGVR="$ugvr" UGVR_STORE="$tmp/mixed.ugvr" timeout -k 5 300 node --test-reporter=spec "$here/controls.test.mjs"
# Cutting planes (web/slices.js), against a viewer of their own.
UGVR="$ugvr" UGVR_STORE="$tmp/mixed.ugvr" timeout -k 5 300 node --test-reporter=spec "$here/slices.test.mjs"
# The engine picker, against a viewer of the mesh itself (exact engine, then its store built in $tmp).
UGVR="$ugvr" UGVR_MESH="$tmp/mixed.vtu" timeout -k 5 300 node --test-reporter=spec "$here/engine.test.mjs"
# The time panel (web/time_panel.js), against a viewer of a 4-step series.
UGVR="$ugvr" UGVR_SERIES="$tmp/wake.pvd" timeout -k 5 300 node --test-reporter=spec "$here/time.test.mjs"
# The same panel over a time store (the level-of-detail engine, steps read at the tab's cut).
UGVR="$ugvr" UGVR_TIME_STORE="$tmp/wake.ugvr" timeout -k 5 300 node --test-reporter=spec "$here/time_store.test.mjs"
# A partitioned store's index in one process (no mpirun), against the whole store's viewer; and one the viewer builds
# for a mesh whose out-of-core build's scratch does not fit.
UGVR="$ugvr" UGVR_PIECES="$tmp/pieces.json" UGVR_STORE="$tmp/mixed.ugvr" timeout -k 5 600 node --test-reporter=spec "$here/pieces.test.mjs"
# The hybrid engine over a store with cells: exact at rest, the engine picker, the interest panel's box and brush.
UGVR="$ugvr" UGVR_CELLS_STORE="$tmp/mixed-cells.ugvr" timeout -k 5 420 node --test-reporter=spec "$here/hybrid.test.mjs"
