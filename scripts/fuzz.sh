#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (ASan + UBSan) and runs each for FUZZ_SECONDS (default 60), seeded with the
# small real files of ../shared/data (or $UGVR_DATA) and the hand-made cases the targets add. Exits non-zero on the
# first crash; the reproducer is left in fuzz-corpus/<target>/crash-*.
#   SEEDS_ONLY=1 UGVR=path/to/ugvr FUZZ_CORPUS=DIR bash scripts/fuzz.sh   writes the seeds only (no clang build): what
#   the FuzzReplay test (scripts/fuzz_replay.sh) replays in CI. UGVR builds the store seeds (skipped without it).
set -euo pipefail
cd "$(dirname "$0")/.."
# Leaks inside the C libraries on a corrupt file (libcgns, libnetcdf, libhdf5: scripts/lsan.supp) are theirs, not
# findings: the sanitizer test run suppresses them the same way.
export LSAN_OPTIONS=suppressions=$PWD/scripts/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}
seconds=${FUZZ_SECONDS:-60}
data=${UGVR_DATA:-../shared/data}
corpus=${FUZZ_CORPUS:-fuzz-corpus}
mkdir -p "$corpus"
corpus=$(cd "$corpus" && pwd)

if [ -z "${SEEDS_ONLY:-}" ]; then
  cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_COMPILER=clang++ -DUGVR_FUZZ=ON -DUGVR_TESTS=OFF -DUGVR_BENCH=OFF >/dev/null
  ninja -C build-fuzz
  UGVR=${UGVR:-build-fuzz/ugvr}
fi

seed() {  # target, files...
  local dir=$corpus/$1/seeds
  shift
  mkdir -p "$dir"
  for f in "$@"; do
    [ -f "$f" ] && [ "$(stat -c %s "$f")" -le 262144 ] && cp "$f" "$dir/"
  done
  return 0
}
seed fuzz_vtk_xml "$data"/vtk-small-ugrids/*.vtu
seed fuzz_vtk_legacy "$data"/vtk-small-ugrids/*.vtk "$data"/vtk-office/*.vtk
# PLOT3D: the real files are too large as seeds; make small ones in the target's input layout (uint32 grid length,
# grid file, Q file) for big- and little-endian, C and Fortran layouts, with and without IBLANK.
/usr/bin/python3 - "$corpus/fuzz_plot3d/seeds" <<'PY'
import os, struct, sys
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
dims = (3, 2, 2)
n = dims[0] * dims[1] * dims[2]
for endian in "<>":
    for fortran in (False, True):
        for iblank in (False, True):
            def rec(payload):
                return struct.pack(endian + "i", len(payload)) + payload + struct.pack(endian + "i", len(payload)) if fortran else payload
            xyz = struct.pack(endian + "%df" % (3 * n), *[float(i % 7) + 0.5 * (i // n) for i in range(3 * n)])
            if iblank:
                xyz += struct.pack(endian + "%di" % n, *[1 if i % 5 else 0 for i in range(n)])
            grid = rec(struct.pack(endian + "3i", *dims)) + rec(xyz)
            q = rec(struct.pack(endian + "3i", *dims)) + rec(struct.pack(endian + "4f", 0.5, 0.0, 1e3, 1.0))
            q += rec(struct.pack(endian + "%df" % (5 * n), *[1.0 + 0.01 * i for i in range(5 * n)]))
            name = "p3d_%s_%s_%s" % ("be" if endian == ">" else "le", "fortran" if fortran else "c", "iblank" if iblank else "plain")
            with open(os.path.join(out, name), "wb") as f:
                f.write(struct.pack("<I", len(grid)) + grid + q)
PY

# ASCII meshes (AVS UCD, TetGen, tetrahedral OFF, NASTRAN): spx.inp and the z88 piston are too large as seeds; make
# small ones of every variant the readers take (TetGen: uint32 length of the .node part, .node, .ele).
/usr/bin/python3 - "$corpus" <<'PY'
import os, struct, sys
root = sys.argv[1]
def put(target, name, data):
    d = os.path.join(root, target, "seeds")
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data.encode() if isinstance(data, str) else data)
cube = [(0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1),(.5,.5,2),(2,0,0),(2,0,1)]
nodes = "".join("%d %g %g %g\n" % ((i + 1,) + p) for i, p in enumerate(cube))
put("fuzz_avs_ucd", "mixed.inp", "# seed\n11 5 4 1 0\n" + nodes +
    "1 1 hex 5 6 7 8 1 2 3 4\n2 1 pyr 9 5 6 7 8\n3 2 prism 2 3 10 6 7 11\n4 2 tet 1 3 2 5\n5 3 tri 1 2 3\n"
    "2 1 3\nt, K\nv, m/s\n" + "".join("%d %d 0 1 2\n" % (i + 1, i) for i in range(11)) +
    "1 1\np, Pa\n" + "".join("%d %d.5\n" % (i + 1, i) for i in range(5)))
put("fuzz_avs_ucd", "tets.inp", "5 2 0 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n5 1 1 1\n1 1 tet 1 3 2 4\n2 1 tet 2 4 3 5\n")
node = "5 3 1 1\n1 0 0 0 10 1\n2 1 0 0 20 1\n3 0 1 0 30 0 # c\n4 0 0 1 40 1\n5 1 1 1 50 0\n"
ele = "2 4 1\n1 1 3 2 4 7\n2 2 4 3 5 8\n"
put("fuzz_tetgen", "tet4", struct.pack("<I", len(node)) + (node + ele).encode())
node10 = "10 3 0 0\n" + "".join("%d %g %g %g\n" % ((i,) + p) for i, p in enumerate(
    [(0,0,0),(1,0,0),(0,1,0),(0,0,1),(.5,0,0),(.5,.5,0),(0,.5,0),(0,0,.5),(.5,0,.5),(0,.5,.5)]))
ele10 = "1 10 0\n0 0 1 2 3 4 5 6 7 8 9\n"
put("fuzz_tetgen", "tet10", struct.pack("<I", len(node10)) + (node10 + ele10).encode())
pts = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n"
put("fuzz_off_tets", "havs.off", "5 2\n" + "".join(l + " %d\n" % i for i, l in enumerate(pts.splitlines())) + "0 1 2 3\n1 2 3 4\n")
put("fuzz_off_tets", "keyword.off", "OFF\n5 2 0\n" + "".join(l + " 1.5\n" for l in pts.splitlines()) + "4 0 2 1 3\n4 1 3 2 4\n")
put("fuzz_off_tets", "cellscalar.off", "5 2\n" + pts + "0 1 2 3 0.5\n1 2 3 4 1.5\n")
put("fuzz_off_tets", "trailing.off", "5 2\n" + pts + "0 1 2 3\n1 2 3 4\n1 2 3 4 5\n")
grid = "".join("GRID,%d,0,%g,%g,%g\n" % ((i + 101,) + p) for i, p in enumerate(cube))
small = lambda name, fields, w=8: name.ljust(8) + "".join(f.rjust(w) for f in fields) + "\n"
put("fuzz_nastran", "mixed.bdf", "SOL 101\nCEND\nBEGIN BULK\n$ c\n" + grid +
    small("GRID", ["120", "", "1.5-1", "0.", "1.+0"]) + small("GRID*", ["121", "5", "1.0", "2.0"], 16) +
    small("*", ["3.0"], 16) + "CORD2R,5,0,1.,0.,0.,1.,0.,1.,\n,2.,0.,0.\n"
    "CHEXA,1,7,101,102,103,104,105,106,\n+,107,108\n" + small("CPYRAM", ["2", "8", "105", "106", "107", "108", "109"]) +
    "CPENTA,3,9,102,110,103,106,111,107\nCTETRA,4,9,101,102,104,105,,,\n,120,121,,\nMAT1,1,7.+4,,.33\nPLOAD4,1,2,5.\n"
    "ENDDATA\n")
put("fuzz_nastran", "tets.nas", "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nGRID,3,,0.,1.,0.\nGRID,4,,0.,0.,1.\nCTETRA,1,1,1,2,3,4\n")
PY

# Gmsh and UGRID: small hand-made meshes in every variant (MSH 2.2 / 4.1, ASCII / binary in both byte orders; UGRID
# ASCII and the ten binary layouts, the first byte picking the file name as fuzz_ugrid.cpp does).
/usr/bin/python3 - "$corpus/fuzz_gmsh/seeds" "$corpus/fuzz_ugrid/seeds" <<'PY'
import os, struct, sys
out_gmsh, out_ugrid = sys.argv[1], sys.argv[2]
os.makedirs(out_gmsh, exist_ok=True)
os.makedirs(out_ugrid, exist_ok=True)
# One hexahedron + one prism + a triangle, node tags sparse (10*i+7).
pts = [(0,0,0),(1,0,0),(1,1,0),(0,1,0),(0,0,1),(1,0,1),(1,1,1),(0,1,1),(2,0,0),(3,0,0),(2,1,0),(2,0,1),(3,0,1),(2,1,1)]
tags = [10*i+7 for i in range(len(pts))]
elems = [(1, 5, 3, tags[0:8]), (2, 6, 3, tags[8:14]), (3, 2, 2, tags[0:3])]
for version in ("2.2", "4.1"):
    for binary in (False, True):
        for e in ("<", ">") if binary else ("<",):
            o = [b"$MeshFormat\n%s %d 8\n" % (version.encode(), binary)]
            if binary: o.append(struct.pack(e + "i", 1) + b"\n")
            o.append(b"$EndMeshFormat\n")
            i = lambda v: struct.pack(e + "i", v) if binary else b"%d " % v
            z = lambda v: struct.pack(e + "Q", v) if binary else b"%d " % v
            d = lambda v: struct.pack(e + "d", v) if binary else b"%r " % float(v)
            nl = b"" if binary else b"\n"
            end = lambda s: (b"\n" if binary else b"") + b"$End" + s + b"\n"
            if version == "2.2":
                o.append(b"$Nodes\n%d\n" % len(pts))
                for t, p in zip(tags, pts): o.append(i(t) + b"".join(d(c) for c in p) + nl)
                o.append(end(b"Nodes") + b"$Elements\n%d\n" % len(elems))
                for tag, typ, dim, ns in elems:
                    o.append((i(typ) + i(1) + i(2) + i(tag)) if binary else (i(tag) + i(typ) + i(2)))
                    o.append(i(9) + i(1) + b"".join(i(n) for n in ns) + nl)
                o.append(end(b"Elements"))
            else:
                o.append(b"$Entities\n" + z(0) + z(0) + z(1) + z(1) + nl)
                o.append(i(1) + b"".join(d(0) for _ in range(6)) + z(0) + z(0) + nl)
                o.append(i(1) + b"".join(d(0) for _ in range(6)) + z(1) + i(9) + z(1) + i(1) + nl + end(b"Entities"))
                o.append(b"$Nodes\n" + z(1) + z(len(pts)) + z(7) + z(tags[-1]) + nl + i(3) + i(1) + i(0) + z(len(pts)) + nl)
                for t in tags: o.append(z(t) + nl)
                for p in pts: o.append(b"".join(d(c) for c in p) + nl)
                o.append(end(b"Nodes") + b"$Elements\n" + z(3) + z(3) + z(1) + z(3) + nl)
                for tag, typ, dim, ns in elems:
                    o.append(i(dim) + i(1) + i(typ) + z(1) + nl + z(tag) + b"".join(z(n) for n in ns) + nl)
                o.append(end(b"Elements"))
            o.append(b"$NodeData\n1\n\"t\"\n1\n0.0\n3\n0\n1\n%d\n" % len(pts))
            for t in tags: o.append((struct.pack(e + "i", t) if binary else b"%d " % t) + d(t * 0.5) + nl)
            o.append(end(b"NodeData"))
            o.append(b"$ElementData\n1\n\"c\"\n1\n0.0\n3\n0\n1\n2\n")
            for t in (1, 2): o.append((struct.pack(e + "i", t) if binary else b"%d " % t) + d(t) + nl)
            o.append(end(b"ElementData"))
            name = "msh%s_%s_%s" % (version.replace(".", ""), "bin" if binary else "ascii", "be" if e == ">" else "le")
            open(os.path.join(out_gmsh, name), "wb").write(b"".join(o))
# UGRID: first byte picks the name (0 ASCII, 1.. the binary suffixes in the order of fuzz_ugrid.cpp); one tet, one
# pyramid, one prism, one hexahedron and a boundary triangle.
layouts = [("", "<", "d", "i", False), ("b8", ">", "d", "i", False), ("lb8", "<", "d", "i", False), ("b4", ">", "f", "i", False),
           ("lb4", "<", "f", "i", False), ("b8l", ">", "d", "q", False), ("lb8l", "<", "d", "q", False), ("r8", ">", "d", "i", True),
           ("lr8", "<", "d", "i", True), ("r4", ">", "f", "i", True), ("lr4", "<", "f", "i", True)]
upts = [(0,0,0),(1,0,0),(0,1,0),(0,0,1), (2,0,0),(2,1,0),(2.5,.5,1),(3,0,0),(3,1,0),
        (4,0,0),(5,0,0),(4,1,0),(4,0,1),(5,0,1),(4,1,1), (6,0,0),(7,0,0),(7,1,0),(6,1,0),(6,0,1),(7,0,1),(7,1,1),(6,1,1)]
header = [len(upts), 1, 0, 1, 1, 1, 1]
ints = [1, 2, 3] + [1] + [1, 2, 3, 4] + [5, 6, 7, 8, 9] + list(range(10, 16)) + list(range(16, 24))
for k, (suffix, e, fl, it, fortran) in enumerate(layouts):
    if not suffix:
        body = " ".join(map(str, header)) + "\n" + "\n".join("%r %r %r" % tuple(map(float, p)) for p in upts) + "\n" + " ".join(map(str, ints)) + "\n"
        data = body.encode()
    else:
        h = struct.pack(e + "7" + it, *header)
        b = struct.pack(e + "%d%s" % (3 * len(upts), fl), *[float(c) for p in upts for c in p]) + struct.pack(e + "%d%s" % (len(ints), it), *ints)
        if fortran:
            h = struct.pack(e + "i", len(h)) + h + struct.pack(e + "i", len(h))
            b = struct.pack(e + "i", len(b)) + b + struct.pack(e + "i", len(b))
        data = h + b
    open(os.path.join(out_ugrid, "ugrid_%s" % (suffix or "ascii")), "wb").write(bytes([k]) + data)
PY

# OpenFOAM: every FoamFile of the generated cases (ascii, binary, gzip; mesh, fields, boundary, cellZones), named by
# their path (many share a name: p, U, faces).
mkdir -p "$corpus/fuzz_openfoam/seeds"
find tests/data/openfoam -type f ! -name '*.foam' ! -name '*.sh' ! -path '*/system/*' | while read -r f; do
  cp "$f" "$corpus/fuzz_openfoam/seeds/$(echo "${f#tests/data/openfoam/}" | tr / _)"
done

# Exodus: the two small real files. NRRD: hand-made attached-data files (raw, big-endian short with space fields,
# gzip, ascii with line skip, 4-D vector with byte skip).
seed fuzz_exodus "$data"/exodus-misc/box-noglom.ex2 "$data"/exodus-misc/mesh_fs8.exo
# CGNS: the shared ADF sample (1 MB, above seed()'s size cap: copied as it is).
mkdir -p "$corpus/fuzz_cgns/seeds"
if [ -f "$data"/cgns-sqnz/sqnz_s.adf.cgns ]; then cp "$data"/cgns-sqnz/sqnz_s.adf.cgns "$corpus/fuzz_cgns/seeds/"; fi
# ... and small ones of every section layout, ADF and HDF5, written by libcgns (fuzz/cgns_seeds.c).
seeds_bin=$(mktemp)
if cc fuzz/cgns_seeds.c -o "$seeds_bin" -lcgns -lm 2>/dev/null; then
  (cd "$corpus/fuzz_cgns/seeds" && "$seeds_bin")
fi
rm -f "$seeds_bin"
/usr/bin/python3 - "$corpus/fuzz_nrrd/seeds" <<'PY'
import gzip, os, struct, sys
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
def hdr(t, sizes, enc, extra=""):
    return ("NRRD0004\ntype: %s\ndimension: %d\nsizes: %s\nencoding: %s\n%s\n" % (t, len(sizes.split()), sizes, enc, extra)).encode()
seeds = {
    "raw.nrrd": hdr("uchar", "2 3 4", "raw", "spacings: 1 2 3\n") + bytes(range(24)),
    "short_be.nrrd": hdr("short", "2 3 4", "raw", "endian: big\nspace directions: (1,0,0) (0,2,0) (0,0,3)\nspace origin: (1,2,3)\n")
    + struct.pack(">24h", *range(24)),
    "gzip.nrrd": hdr("float", "2 3 4", "gzip", "endian: little\ncontent: f\n") + gzip.compress(struct.pack("<24f", *range(24))),
    "ascii.nrrd": hdr("int", "2 3 4", "ascii", "line skip: 1\n") + b"skip me\n" + " ".join(str(i) for i in range(24)).encode(),
    "vec.nrrd": hdr("uchar", "3 2 3 4", "raw", "space directions: none (1,0,0) (0,1,0) (0,0,1)\nbyte skip: 2\n") + b"xx" + bytes(range(72)),
}
for name, data in seeds.items():
    with open(os.path.join(out, name), "wb") as f:
        f.write(data)
PY

# The viewer's protocol: one message per file, valid ones of every type and a few near misses.
/usr/bin/python3 - "$corpus/fuzz_view_protocol/seeds" <<'PY'
import os, sys
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
messages = [
    '{"type":"hello","width":640,"height":480}',
    '{"type":"resize","width":32,"height":24}',
    '{"type":"camera","position":[1,2,3],"focal_point":[0,0,0],"view_up":[0,0,1],"view_angle":30,"request":7}',
    '{"type":"tf","points":[[0,0,0,0,0],[1,1,1,1,0.5]],"range":[0,1]}',
    '{"type":"settings","volume_lighting":true,"step":0.5,"background":[0,0,0,1]}',
    '{"type":"engine","engine":"exact"}',
    '{"type":"camera","position":[1e308,-1e308,0]}',
    '{"type":"hello","width":-1,"height":1e9}',
    '[{"type":"hello"}]',
]
for i, m in enumerate(messages):
    open(os.path.join(out, "m%02d.json" % i), "w").write(m)
PY

# Cameras, render settings and ParaView presets: the first byte picks the parser (fuzz_settings_files.cpp).
/usr/bin/python3 - "$corpus/fuzz_settings_files/seeds" <<'PY'
import os, sys
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
files = {
    "camera": (0, '{"position":[1,2,3],"focal_point":[0,0,0],"view_up":[0,0,1],"view_angle":30,"parallel_projection":false}'),
    "camera-parallel": (0, '{"position":[0,0,5],"focal_point":[0,0,0],"view_up":[0,1,0],"parallel_projection":true,"parallel_scale":2}'),
    "settings": (1, '{"mode":"iso","iso_values":[0.5,0.7],"volume_lighting":true,"background":[0,0,0,1],"step":0.25}'),
    "settings-clip": (1, '{"clip":{"origin":[0,0,0],"normal":[1,0,0]},"early_termination_opacity":0.95}'),
    "preset": (2, '[{"Name":"Cool","ColorSpace":"Diverging","RGBPoints":[0,0.2,0.3,0.9,1,0.7,0.0,0.1],'
                  '"Points":[0,0,0.5,0,1,1,0.5,0]}]'),
}
for name, (kind, text) in files.items():
    open(os.path.join(out, name), "wb").write(bytes([kind]) + text.encode())
PY

# Time-series manifests (fuzz_time_series.cpp: first byte 0 .pvd, 1 .series, 2 a step selection after a count byte),
# naming the empty a.vtu, b.vtu, c.vtk the target writes beside them.
/usr/bin/python3 - "$corpus/fuzz_time_series/seeds" <<'PY'
import os, sys
d = sys.argv[1]
os.makedirs(d, exist_ok=True)
seeds = {
    "pvd": b"\0" + b"""<?xml version="1.0"?>
<VTKFile type="Collection" version="0.1">
  <Collection>
    <DataSet timestep="0" part="0" file="a.vtu"/>
    <DataSet timestep="0.5" part="0" file="b.vtu"/>
    <DataSet timestep="0.5" part="1" file="c.vtk"/>
  </Collection>
</VTKFile>
""",
    "pvd-bad": b"\0<VTKFile type=\"Collection\"><Collection><DataSet timestep=\"2\" file=\"a.vtu\"/><DataSet timestep=\"1\" file=\"b.vtu\"/></Collection></VTKFile>",
    "series": b"\1" + b'{"file-series-version": "1.0", "files": [{"name": "a.vtu", "time": 0}, {"name": "b.vtu", "time": 1.5}]}',
    "series-missing": b"\1" + b'{"files": [{"name": "nope.vtu", "time": 0}]}',
    "steps-range": b"\2\x15" + b"2:18:4",
    "steps-all": b"\2\x03" + b"all",
}
for name, data in seeds.items():
    open(os.path.join(d, name), "wb").write(data)
PY

# Brick stores: small ones built by ugvr itself (quantised and float, one and two fields, one keeping its leaves'
# cells, and one of three time steps: format version 6's steps section).
if [ -n "${UGVR:-}" ] && [ -x "${UGVR:-}" ]; then
  mkdir -p "$corpus/fuzz_store/seeds"
  tmp=$(mktemp -d)
  "$UGVR" --quiet generate --cells 1000 --kind mixed -o "$tmp/g.vtu" >/dev/null
  "$UGVR" --quiet build "$tmp/g.vtu" -o "$corpus/fuzz_store/seeds/q16.ugvr" --brick 8 --max-depth 2 >/dev/null
  "$UGVR" --quiet build "$tmp/g.vtu" -o "$corpus/fuzz_store/seeds/f32.ugvr" --brick 8 --max-depth 1 --float32 \
    --fields pressure,velocity >/dev/null
  "$UGVR" --quiet build "$tmp/g.vtu" -o "$corpus/fuzz_store/seeds/cells.ugvr" --brick 4 --max-depth 1 --cells >/dev/null
  "$UGVR" --quiet generate --cells 1000 --time-steps 3 -o "$tmp/t.pvd" >/dev/null
  "$UGVR" --quiet build "$tmp/t.pvd" --time all -o "$corpus/fuzz_store/seeds/time.ugvr" --brick 4 --max-depth 1 \
    >/dev/null
  rm -rf "$tmp"
fi

# EnSight: every shared sample case with its geometry and first variable file, the case rewritten to name f.geo and
# f.var (the target's layout: uint32 case length, uint32 geometry length, case, geometry, variable).
/usr/bin/python3 - "$data/ensight-samples" "$corpus/fuzz_ensight/seeds" <<'PY'
import glob, os, re, struct, sys
src, out = sys.argv[1], sys.argv[2]
os.makedirs(out, exist_ok=True)
for case in sorted(glob.glob(os.path.join(src, "*.case"))):
    text = open(case).read()
    model = re.search(r"^model:(.*)$", text, re.M)
    if not model:
        continue
    geo = model.group(1).split()[-1]
    var = re.search(r"^[a-z ]+per (?:node|element):(.*)$", text, re.M)
    text = text.replace(geo, "f.geo", 1)
    var_bytes = b""
    if var:
        name = var.group(1).split()[-1]
        path = os.path.join(src, name.replace("****", "0001"))
        if os.path.exists(path):
            var_bytes = open(path, "rb").read()
        text = re.sub(r"^(%s)$" % re.escape(var.group(0)), var.group(0).replace(name, "f.var"), text, count=1, flags=re.M)
        text = "\n".join(l for l in text.split("\n") if not re.match(r"^[a-z ]+per (node|element):", l) or "f.var" in l)
    geo_bytes = open(os.path.join(src, geo), "rb").read()
    data = struct.pack("<II", len(text), len(geo_bytes)) + text.encode() + geo_bytes + var_bytes
    if len(data) <= 262144:
        open(os.path.join(out, os.path.basename(case)), "wb").write(data)
PY

[ -n "${SEEDS_ONLY:-}" ] && exit 0

status=0
for bin in build-fuzz/fuzz/fuzz_*; do
  [ -x "$bin" ] || continue
  name=$(basename "$bin")
  bin=$(pwd)/$bin
  mkdir -p "$corpus/$name/work" "$corpus/$name/seeds"
  echo "== $name: ${seconds}s"
  if ! (cd "$corpus/$name" && "$bin" -max_total_time="$seconds" -max_len=262144 -rss_limit_mb=4096 \
        -timeout=10 -print_final_stats=1 work seeds 2>&1 | tail -n 12); then
    echo "$name: FAILED"
    status=1
  fi
done
exit $status
