#!/usr/bin/env python3
"""Writes the regression inputs of fuzz/regression/ again: each one the smallest project-made form of an input that
once got wrong data or a crash past a reader (issue 23's findings), named after what it found. The FuzzReplay test
replays them, and deterministic mutations of them, in the release and the ASan + UBSan builds.

Usage: make_regression.py UGVR OUT_DIR   (UGVR builds the small store the store inputs are made from)
"""
import gzip
import os
import struct
import subprocess
import sys
import tempfile
import zlib

import numpy as np
from scipy.io import netcdf_file

ugvr, out = sys.argv[1], sys.argv[2]


def put(target, name, data):
    d = os.path.join(out, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


# --- NRRD, gzip: the reader stopped when the array was full and never checked the gzip trailer; 6 of 30 bit flips
# came back as values (+-3e38, NaN). Here the CRC-32 in the trailer is flipped, and a second file has a data bit
# flipped with the CRC left as it was.
head = b"NRRD0004\ntype: float\ndimension: 3\nsizes: 2 3 4\nencoding: gzip\nendian: little\n\n"
body = bytearray(gzip.compress(struct.pack("<24f", *range(24)), mtime=0))
crc = bytearray(body)
crc[-8] ^= 0x10
put("fuzz_nrrd", "gzip-crc-flipped.nrrd", head + bytes(crc))
flip = bytearray(body)
flip[14] ^= 0x01  # inside the deflate stream
put("fuzz_nrrd", "gzip-data-bit-flipped.nrrd", head + bytes(flip))

# --- VTK XML: duplicated <Points> (the second silently replaced the first) and an id in an unused mid-edge slot.
pts = " ".join("%g %g %g" % p for p in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)])
def vtu(points_block, conn="0 1 2 3", types="10", offsets="4"):
    return ('<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">\n'
            '<UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">\n' + points_block +
            '<Cells><DataArray type="Int64" Name="connectivity" format="ascii">%s</DataArray>\n'
            '<DataArray type="Int64" Name="offsets" format="ascii">%s</DataArray>\n'
            '<DataArray type="UInt8" Name="types" format="ascii">%s</DataArray></Cells>\n'
            '</Piece></UnstructuredGrid></VTKFile>\n' % (conn, offsets, types)).encode()
points = '<Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">%s</DataArray></Points>\n' % pts
put("fuzz_vtk_xml", "duplicated-points.vtu", vtu(points + points.replace(" 1 ", " 7 ")))
# A quadratic tetrahedron (type 24, 10 ids) whose mid-edge ids point past the 4 points.
put("fuzz_vtk_xml", "quadratic-tet-mid-edge-out-of-range.vtu", vtu(points, "0 1 2 3 4 5 6 7 8 99", "24", "10"))

# --- Exodus (netCDF-3): a file cut inside its nodal variable's data read back zeros or another variable's values
# with exit 0 (netCDF fills reads past the end of the file). One tetrahedron, two nodal variables, three steps; cut
# inside vals_nod_var2.
with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "tet.exo")
    f = netcdf_file(path, "w", version=2)
    for name, n in [("time_step", None), ("len_string", 33), ("len_name", 33), ("num_dim", 3), ("num_nodes", 4),
                    ("num_elem", 1), ("num_el_blk", 1), ("num_el_in_blk1", 1), ("num_nod_per_el1", 4),
                    ("num_nod_var", 2)]:
        f.createDimension(name, n)
    f.api_version = np.float32(8.0)
    f.version = np.float32(8.0)
    f.floating_point_word_size = np.int32(8)
    f.file_size = np.int32(1)
    t = f.createVariable("time_whole", "d", ("time_step",))
    for axis, values in zip("xyz", [(0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)]):
        f.createVariable("coord" + axis, "d", ("num_nodes",))[:] = values
    f.createVariable("eb_status", "i", ("num_el_blk",))[:] = [1]
    f.createVariable("eb_prop1", "i", ("num_el_blk",))[:] = [1]
    f.variables["eb_prop1"].name = b"ID"
    c = f.createVariable("connect1", "i", ("num_el_in_blk1", "num_nod_per_el1"))
    c[:] = [[1, 2, 3, 4]]
    c.elem_type = b"TETRA"
    names = f.createVariable("name_nod_var", "c", ("num_nod_var", "len_name"))
    names[0, :4] = list(b"temp")
    names[1, :5] = list(b"press")
    v1 = f.createVariable("vals_nod_var1", "d", ("time_step", "num_nodes"))
    v2 = f.createVariable("vals_nod_var2", "d", ("time_step", "num_nodes"))
    for s in range(3):
        t[s] = 0.5 * s
        v1[s, :] = [s, s + 1, s + 2, s + 3]
        v2[s, :] = [10 * s, 10 * s + 1, 10 * s + 2, 10 * s + 3]
    f.close()
    whole = open(path, "rb").read()
    put("fuzz_exodus", "truncated-in-the-last-step.exo", whole[: len(whole) - 20])

# --- Brick store: values the format cannot hold, checksums recomputed, once rendered: the field range
# [+inf, -inf] and a varying root block with qmax 0 (offsets: src/ugvr/store/brick_store_format.h, version 5).
with tempfile.TemporaryDirectory() as tmp:
    mesh, store = os.path.join(tmp, "g.vtu"), os.path.join(tmp, "s.ugvr")
    subprocess.run([ugvr, "--quiet", "generate", "--cells", "1000", "--kind", "tet", "-o", mesh], check=True,
                   stdout=subprocess.DEVNULL)
    subprocess.run([ugvr, "--quiet", "build", mesh, "-o", store, "--brick", "4", "--max-depth", "1", "--fields",
                    "pressure"], check=True, stdout=subprocess.DEVNULL)
    good = bytearray(open(store, "rb").read())

u32 = lambda f, at: struct.unpack_from("<I", f, at)[0]
u64 = lambda f, at: struct.unpack_from("<Q", f, at)[0]
assert u32(good, 8) == 5, "make_regression.py knows the offsets of store version 5"
table, record = u64(good, 152), u32(good, 24)


def reseal(f):
    struct.pack_into("<I", f, 168, zlib.crc32(bytes(f[table:])))
    header_size = u32(f, 12)
    struct.pack_into("<I", f, 172, 0)
    struct.pack_into("<I", f, 172, zlib.crc32(bytes(f[:header_size])))
    return bytes(f)


field0 = 176 + 24 + 40 + 32  # header_records_size(5)
f = bytearray(good)
struct.pack_into("<dd", f, field0, float("inf"), float("-inf"))
put("fuzz_store", "field-range-inf-to-minus-inf.ugvr", reseal(f))
f = bytearray(good)
block = u64(f, table + 16)  # node 0's brick_offset
entry = table + 48  # node 0, field 0
size = u32(f, entry + 16)
assert u32(f, block + 20) > 0
struct.pack_into("<I", f, block + 20, 0)  # qmax
struct.pack_into("<I", f, entry + 20, zlib.crc32(bytes(f[block:block + size])))
put("fuzz_store", "root-block-qmax-0.ugvr", reseal(f))
