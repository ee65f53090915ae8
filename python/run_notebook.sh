#!/usr/bin/env bash
# Executes a notebook (docs/python-demo.ipynb) top to bottom with nbconvert, as CI does (ctest PythonNotebook), into
# OUT_DIR/executed.ipynb; the images it saves go to OUT_DIR/images (UGVR_NOTEBOOK_IMAGES), not into docs/. Exits 77
# (skipped) when nbconvert or ipykernel is missing. UGVR_PYTHON names the interpreter (default python3).
set -euo pipefail
notebook=$1
out=$2
py=${UGVR_PYTHON:-python3}
if ! "$py" -c "import nbconvert, ipykernel" 2>/dev/null; then
  echo "skipped: needs jupyter-nbconvert and python3-ipykernel (scripts/install-deps.sh)"
  exit 77
fi
export UGVR_NOTEBOOK_IMAGES="$out/images"
rm -rf "$out"
mkdir -p "$UGVR_NOTEBOOK_IMAGES"
"$py" -m nbconvert --to notebook --execute --ExecutePreprocessor.timeout=240 --output-dir "$out" --output executed \
  "$notebook"
# The notebook saves every image it shows; each must be a PNG that is not a single colour.
count=0
for png in "$UGVR_NOTEBOOK_IMAGES"/python-*.png; do
  [ -e "$png" ] || continue
  "$py" - "$png" <<'PY'
import sys
import numpy as np
import ugvr
image = ugvr.read_image(sys.argv[1]).array
assert image.shape[0] > 16 and image.shape[1] > 16, sys.argv[1]
assert len(np.unique(image.reshape(-1, 4), axis=0)) > 50, f"{sys.argv[1]}: nearly one colour"
PY
  count=$((count + 1))
done
[ "$count" -ge 3 ] || { echo "the notebook saved $count images, expected at least 3"; exit 1; }
echo "notebook ran; $count images checked"
