#!/usr/bin/env bash
# Tricubic isosurfaces in the LOD engine (docs/tricubic.md): frame time of --interpolation tricubic against trilinear
# on one voxel input, and the picture pair of docs/tricubic.md.
# The input: a sphere's distance field |p - c| (c the centre, radius 0.3 of the unit cube's side as the iso value)
# sampled on N³ points (default 33: spacing 1/32, the coarse grid of issue 22), written as a little-endian float NRRD
# (spacings 1/(N-1): the unit cube), built into a store with leaf bricks of 9 samples at depth 2 (8 voxels of 1/32 per node axis, so
# the leaf samples are the NRRD's own) and rendered at SIZE² (default 512) from an oblique camera, FRAMES frames each
# way (default 5; the median after the first, `--stats`'s median_frame_seconds), alternated ROUNDS times (default 2).
# FIELD=sines instead samples sin(3πx) sin(3πy) sin(3πz) (iso 0.25: blobs of about 3 voxels' radius, the field of
# tests/test_lod_tricubic.cpp), and BRICKS=1 builds one brick of N samples (depth 0) instead of 64 bricks of 9.
# PER_BRICK=1 adds, in each round, tricubic with each brick prefiltered alone (UGVR_TRICUBIC_EXTENSION=0, as before
# the same-level neighbourhood of docs/tricubic.md, "Seams") after the default (the neighbourhood): frame time and the
# first frame's upload time (load_seconds, all bricks uploaded then) before/after in one run.
# LEVELS=1 adds, in each round, tricubic without the level blend (UGVR_TRICUBIC_LEVEL_BLEND=0: each level's own
# spline, as before docs/tricubic.md's "Level borders") after the default; with CUT=pixels:N (default leaves) the cut
# mixes levels, so that the blend's extra upload (the ancestors' neighbourhoods) and its frame time show.
# FILL=1 adds, in each round, tricubic without the fill of samples without data (UGVR_TRICUBIC_FILL=0: bricks with
# samples without data keep their samples and their neighbours drop that side, as before docs/tricubic.md's "Samples
# without data") after the default; it matters only on a store with samples outside the mesh: STORE=PATH ISO=V
# renders that store (its first field; e.g. the blunt fin's Density) instead of the generated NRRD's, from the default
# view framed on its data.
# BASE=PATH adds, in each round, tricubic drawn by another ugvr binary (e.g. one built at the commit before a change:
# variant tricubic-base) after the default, for before/after of a change that no environment variable turns off;
# BASE2=PATH a second one after it (variant tricubic-base2).
# Usage: bench/run_tricubic.sh [OUT_DIR=/tmp/ugvr-tricubic]; UGVR (default build/ugvr), N, SIZE, FRAMES, ROUNDS,
# FIELD (sphere), BRICKS (64), PER_BRICK, LEVELS, FILL, BASE, BASE2, CUT (leaves), STORE, ISO, PYTHON. One JSON line per render is appended to bench/results/tricubic.jsonl.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/ugvr-tricubic}
ugvr=${UGVR:-$PWD/build/ugvr}
n=${N:-33}
size=${SIZE:-512}
frames=${FRAMES:-5}
rounds=${ROUNDS:-2}
py=${PYTHON:-$(command -v python3)}
field=${FIELD:-sphere}
bricks=${BRICKS:-64}
case "$field" in sphere) iso=0.3 ;; sines) iso=0.25 ;; *) echo "FIELD must be sphere or sines" >&2; exit 2 ;; esac
case "$bricks" in 64) brick_args="--brick 9 --max-depth 2" ;; 1) brick_args="--brick $n --max-depth 0" ;;
  *) echo "BRICKS must be 1 or 64" >&2; exit 2 ;; esac
jsonl=bench/results/tricubic.jsonl
mkdir -p "$out" bench/results
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
echo "{\"bench\":\"session\",\"date\":\"$(date -u +%FT%TZ)\",\"commit\":\"$commit\",\"machine\":\"$(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg)\"}" | tee -a "$jsonl"

if [ -n "${STORE:-}" ]; then
  [ -n "${ISO:-}" ] || { echo "STORE needs ISO" >&2; exit 2; }
  field=$(basename "$STORE" .ugvr) iso=$ISO bricks=0
fi
nrrd="$out/$field$n.nrrd"
[ -z "${STORE:-}" ] && "$py" - "$nrrd" "$n" "$field" <<'PY'
import math, struct, sys
path, n, field = sys.argv[1], int(sys.argv[2]), sys.argv[3]
h = 1.0 / (n - 1)
k3 = 3 * math.pi
vals = []
for k in range(n):
    for j in range(n):
        for i in range(n):
            if field == "sines":
                vals.append(math.sin(k3 * i * h) * math.sin(k3 * j * h) * math.sin(k3 * k * h))
            else:
                vals.append(math.sqrt((i * h - 0.5) ** 2 + (j * h - 0.5) ** 2 + (k * h - 0.5) ** 2))
with open(path, "wb") as f:
    f.write(("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nspacings: %r %r %r\nencoding: raw\n"
             "endian: little\n\n" % (n, n, n, h, h, h)).encode())
    f.write(struct.pack("<%df" % len(vals), *vals))
PY
store=${STORE:-$out/$field$n-$bricks.ugvr}
# shellcheck disable=SC2086 # two arguments
[ -z "${STORE:-}" ] && "$ugvr" --quiet build "$nrrd" $brick_args --error 0 -o "$store"
cat > "$out/camera.json" <<'CAM'
{"position": [1.6, 1.3, 2.0], "focal_point": [0.5, 0.5, 0.5], "view_up": [0, 1, 0], "view_angle": 24}
CAM
camera_args=(--camera "$out/camera.json")
[ -n "${STORE:-}" ] && camera_args=()
variants="trilinear tricubic"
[ "${PER_BRICK:-0}" = 1 ] && variants="$variants tricubic-per-brick"
[ "${LEVELS:-0}" = 1 ] && variants="$variants tricubic-no-level-blend"
[ "${FILL:-0}" = 1 ] && variants="$variants tricubic-no-fill"
[ -n "${BASE:-}" ] && variants="$variants tricubic-base"
[ -n "${BASE2:-}" ] && variants="$variants tricubic-base2"
cut=${CUT:-leaves}
upload_size=64
[ "$cut" != leaves ] && upload_size=$size
for round in $(seq "$rounds"); do
  for variant in $variants; do
    interp=${variant%%-*}
    extension=""
    [ "$variant" = tricubic-per-brick ] && extension=0
    blend=""
    [ "$variant" = tricubic-no-level-blend ] && blend=0
    fill=""
    [ "$variant" = tricubic-no-fill ] && fill=0
    binary=$ugvr
    [ "$variant" = tricubic-base ] && binary=$BASE
    [ "$variant" = tricubic-base2 ] && binary=$BASE2
    UGVR_TRICUBIC_EXTENSION=$extension UGVR_TRICUBIC_LEVEL_BLEND=$blend UGVR_TRICUBIC_FILL=$fill "$binary" --quiet render "$store" --tf viridis --engine lod --cut "$cut" \
      "${camera_args[@]}" --size "$size" --iso $iso --interpolation "$interp" -o "$out/$variant.png" \
      --stats "$out/$variant.json" --frames "$frames"
    # The upload: one frame at 64² (its stats are the frame that uploads every brick of the cut); at SIZE² with a
    # CUT other than leaves (a pixels cut depends on the image's size).
    UGVR_TRICUBIC_EXTENSION=$extension UGVR_TRICUBIC_LEVEL_BLEND=$blend UGVR_TRICUBIC_FILL=$fill "$binary" --quiet render "$store" --tf viridis --engine lod --cut "$cut" \
      "${camera_args[@]}" --size "$upload_size" --iso $iso --interpolation "$interp" -o "$out/$variant-64.png" \
      --stats "$out/$variant-upload.json" --frames 1
    "$py" -c "
import json; s = json.load(open('$out/$variant.json')); u = json.load(open('$out/$variant-upload.json'))
print(json.dumps({'bench': 'tricubic', 'field': '$field', 'bricks': $bricks, 'interpolation': '$variant', 'n': $n,
                  'cut': '$cut', 'cut_nodes': u.get('cut_nodes'), 'mean_level': u.get('cut_mean_level'),
                  'size': $size, 'round': $round, 'median_frame_seconds': s['median_frame_seconds'],
                  'upload_seconds': u['load_seconds'], 'bricks_loaded': u['bricks_loaded_last_frame'],
                  'neighbour_reads': u.get('neighbour_reads'), 'uploaded_bytes': u.get('uploaded_bytes'),
                  'cubic_prefilters': u.get('cubic_prefilters')}))" \
      | tee -a "$jsonl"
  done
done
