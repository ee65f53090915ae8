#!/usr/bin/env bash
# Regenerates the OpenFOAM test cases of this folder with Debian's `openfoam` package (v1912; not a CI dependency:
# the generated files are committed). Run from anywhere: bash tests/data/openfoam/make_fixtures.sh
#   cavity/          the icoFoam lid-driven cavity tutorial (20x20x1 hexahedra), ascii, time dirs 0 0.1 0.2 0.3,
#                    plus a cellZone "lid" (topoSet) so that constant/polyMesh/cellZones exists
#   cavity_binary/   the same case converted by foamFormatConvert to writeFormat binary (uncompressed)
#   cavity_gzip/     cavity_binary/ with its mesh and field files gzip-compressed by hand (OpenFOAM v1912 resets
#                    "binary + writeCompression on" to uncompressed binary, calling it ineffective; OpenFOAM and
#                    VTK read a *.gz binary file all the same)
#   cavity_ascii_gz/ the same case, ascii with writeCompression on
#   cavity_decomposed/  decomposePar, 2 processors (method simple, 2x1x1) of cavity/, only the processor*/ directories kept
#   dual/            polyDualMesh of a 6x6x6 hexahedral box (all cells polyhedra), with icoFoam run for 0.02 s
# Each case gets an empty <case>.foam file (ParaView's convention).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tut=/usr/share/doc/openfoam-examples/examples/incompressible/icoFoam/cavity/cavity
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
set +u
# shellcheck disable=SC1091
source /usr/share/openfoam/etc/bashrc >/dev/null 2>&1 || true
set -u
export OMPI_MCA_plm=isolated OMPI_MCA_btl_vader_single_copy_mechanism=none

set_dict() {  # file key value: replaces "key  anything;" in an OpenFOAM dictionary
  sed -i -E "s/^($2[[:space:]]+)[^;]*;/\1$3;/" "$1"
}
clean_case() {  # removes what the tests do not read
  rm -rf "$1"/log.* "$1"/*.obj "$1"/*/uniform "$1"/processor*/*/uniform "$1"/constant/polyMesh/sets \
    "$1"/processor*/constant/polyMesh/sets
}

# --- cavity: ascii, 3 written time steps, a cell zone ---
c=$work/cavity
cp -r "$tut" "$c"
set_dict "$c/system/controlDict" endTime 0.3
cat > "$c/system/topoSetDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object topoSetDict; }
actions
(
    { name lidCells; type cellSet; action new; source boxToCell; box (0 0.08 -1) (0.1 0.1 1); }
    { name lid; type cellZoneSet; action new; source setToCellZone; set lidCells; }
);
DICT
(cd "$c" && blockMesh >log.blockMesh && topoSet >log.topoSet && icoFoam >log.icoFoam)

convert() {  # name format compression
  local d=$work/$1
  cp -r "$c" "$d"
  set_dict "$d/system/controlDict" writeFormat "$2"
  set_dict "$d/system/controlDict" writeCompression "$3"
  (cd "$d" && foamFormatConvert >log.convert)
  # foamFormatConvert leaves the uncompressed originals beside the .gz files; keep one copy of each.
  if [ "$3" = on ]; then
    find "$d" -name '*.gz' | while read -r gz; do rm -f "${gz%.gz}"; done
  fi
}
convert cavity_binary binary off
cp -r "$work/cavity_binary" "$work/cavity_gzip"
find "$work/cavity_gzip/constant/polyMesh" "$work"/cavity_gzip/0* -type f -exec gzip -n -9 {} +
convert cavity_ascii_gz ascii on

# --- decomposed ---
d=$work/cavity_decomposed
cp -r "$c" "$d"
cat > "$d/system/decomposeParDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object decomposeParDict; }
numberOfSubdomains 2;
method simple;
simpleCoeffs { n (2 1 1); delta 0.001; }
DICT
(cd "$d" && decomposePar -time '0:' >log.decomposePar && rm -rf constant/polyMesh 0 0.1 0.2 0.3)

# --- dual: polyhedra ---
p=$work/dual
cp -r "$tut" "$p"
cat > "$p/system/blockMeshDict" <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object blockMeshDict; }
scale 0.1;
vertices ((0 0 0) (1 0 0) (1 1 0) (0 1 0) (0 0 1) (1 0 1) (1 1 1) (0 1 1));
blocks (hex (0 1 2 3 4 5 6 7) (6 6 6) simpleGrading (1 1 1));
boundary
(
    movingWall { type wall; faces ((3 7 6 2)); }
    fixedWalls { type wall; faces ((0 4 7 3) (2 6 5 1) (1 5 4 0) (0 3 2 1) (4 5 6 7)); }
);
DICT
sed -i -e '/frontAndBack/,/}/d' "$p/0/U" "$p/0/p"
set_dict "$p/system/controlDict" endTime 0.02
set_dict "$p/system/controlDict" deltaT 0.001
set_dict "$p/system/controlDict" writeInterval 20
(cd "$p" && blockMesh >log.blockMesh && polyDualMesh 60 -overwrite >log.polyDualMesh && icoFoam >log.icoFoam)

for k in cavity cavity_binary cavity_gzip cavity_ascii_gz cavity_decomposed dual; do
  clean_case "$work/$k"
  rm -rf "${here:?}/$k"
  cp -r "$work/$k" "$here/$k"
  : >"$here/$k/$k.foam"
done
du -sh "$here"
