#!/usr/bin/env bash
# Renders every scene of scenes.txt into tests/golden/NAME.pfm with the given build (the reference images of
# test_golden_images.cpp), and records the GL renderer the LOD scenes were drawn with in renderer.txt.
# Usage: tests/golden/make_references.sh [UGVR=build/ugvr]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
ugvr=$(realpath "${1:-$here/../../build/ugvr}")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# Must match GoldenImages' set-up in test_golden_images.cpp.
"$ugvr" --quiet generate --cells 3000 --kind mixed -o "$tmp/mesh.vtu"
"$ugvr" --quiet build "$tmp/mesh.vtu" --fields pressure,velocity:magnitude --brick 8 --max-depth 4 --threads 1 \
  -o "$tmp/store.ugvr"
grep -v '^#' "$here/scenes.txt" | while IFS='|' read -r name input args; do
  name=$(echo $name) input=$(echo $input)
  # shellcheck disable=SC2086
  "$ugvr" --quiet render "$tmp/$input.$([ "$input" = mesh ] && echo vtu || echo ugvr)" $args -o "$here/$name.pfm" \
    --stats "$tmp/$name.json" </dev/null
  echo "$name"
done
/usr/bin/python3 -c "import json; print(json.load(open('$tmp/lod-leaves.json'))['renderer'])" >"$here/renderer.txt"
