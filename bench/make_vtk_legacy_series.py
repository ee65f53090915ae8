#!/usr/bin/python3
"""Writes a time series of BINARY legacy VTK files on one static hexahedral mesh, for the fields-only step switch
benchmark (bench/run_vtk_legacy_switch.sh, issue 18 [time]).

usage: make_vtk_legacy_series.py OUT_DIR [--n N (100: N^3 cells)] [--steps S (3)] [--ascii]

Writes OUT_DIR/flow_000k.vtk (k = 0..S-1) and OUT_DIR/flow.pvd. Each file is a VTK 5.1 UNSTRUCTURED_GRID as
vtkUnstructuredGridWriter writes it: a title and a dataset-level FIELD with the step's TIME (both differ per step),
POINTS float, CELLS with vtktypeint64 OFFSETS and CONNECTIVITY, CELL_TYPES, then POINT_DATA pressure (float) and
velocity (float, 3 components) and CELL_DATA vorticity (float): a vortex that moves downstream with the step. The
mesh bytes are the same in every file, only the fields change. --ascii writes the same as ASCII text (floats with 9
significant digits, which read back to the same float32 values).
"""
import argparse
import os

import numpy as np


def mesh(n):
    p = n + 1
    g = np.arange(p, dtype=np.float32) / n
    z, y, x = np.meshgrid(g, g, g, indexing="ij")  # point i + p*(j + p*k)
    points = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    i, j, k = k.ravel(), j.ravel(), i.ravel()  # cell i + n*(j + n*k)

    def pid(a, b, c):
        return a + p * (b + p * c)

    corners = [pid(i, j, k), pid(i + 1, j, k), pid(i + 1, j + 1, k), pid(i, j + 1, k),
               pid(i, j, k + 1), pid(i + 1, j, k + 1), pid(i + 1, j + 1, k + 1), pid(i, j + 1, k + 1)]
    connectivity = np.stack(corners, axis=1).astype(np.int64).ravel()
    return points, connectivity, n ** 3


ASCII = False


def block(f, header, array, dtype):
    f.write((header + "\n").encode())
    values = np.ascontiguousarray(array, dtype=dtype)
    if ASCII:
        np.savetxt(f, values.reshape(-1, 1) if values.ndim == 1 else values,
                   fmt="%d" if dtype.startswith(">i") else "%.9g")
        return
    f.write(values.tobytes())
    f.write(b"\n")


def write_step(path, points, connectivity, cells, t):
    x, y, z = points[:, 0], points[:, 1], points[:, 2]
    cx = 0.2 + 0.3 * t
    r2 = (x - cx) ** 2 + (y - 0.5) ** 2
    pressure = (1.0 - np.exp(-r2 * 40.0) + 0.1 * z).astype(np.float32)
    velocity = np.stack([1.0 - (y - 0.5) * np.exp(-r2 * 40.0), (x - cx) * np.exp(-r2 * 40.0), 0.0 * z], axis=1)
    centres = points[connectivity.reshape(-1, 8)[:, 0]]
    vorticity = np.exp(-((centres[:, 0] - cx) ** 2 + (centres[:, 1] - 0.5) ** 2) * 40.0)
    with open(path, "wb") as f:
        f.write(b"# vtk DataFile Version 5.1\n")
        f.write(("flow at t = %g\n%s\nDATASET UNSTRUCTURED_GRID\n" % (t, "ASCII" if ASCII else "BINARY")).encode())
        block(f, "FIELD FieldData 1\nTIME 1 1 double", [t], ">f8")
        block(f, "POINTS %d float" % len(points), points, ">f4")
        f.write(("CELLS %d %d\n" % (cells + 1, len(connectivity))).encode())
        block(f, "OFFSETS vtktypeint64", np.arange(cells + 1, dtype=np.int64) * 8, ">i8")
        block(f, "CONNECTIVITY vtktypeint64", connectivity, ">i8")
        block(f, "CELL_TYPES %d" % cells, np.full(cells, 12), ">i4")
        f.write(("POINT_DATA %d\n" % len(points)).encode())
        block(f, "SCALARS pressure float 1\nLOOKUP_TABLE default", pressure, ">f4")
        block(f, "VECTORS velocity float", velocity, ">f4")
        f.write(("CELL_DATA %d\n" % cells).encode())
        block(f, "SCALARS vorticity float 1\nLOOKUP_TABLE default", vorticity, ">f4")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out_dir")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--steps", type=int, default=3)
    ap.add_argument("--ascii", action="store_true")
    a = ap.parse_args()
    global ASCII
    ASCII = a.ascii
    os.makedirs(a.out_dir, exist_ok=True)
    points, connectivity, cells = mesh(a.n)
    entries = []
    for k in range(a.steps):
        name = "flow_%04d.vtk" % k
        write_step(os.path.join(a.out_dir, name), points, connectivity, cells, 0.5 * k)
        entries.append('    <DataSet timestep="%g" part="0" file="%s"/>\n' % (0.5 * k, name))
    with open(os.path.join(a.out_dir, "flow.pvd"), "w") as f:
        f.write('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n')
        f.write("".join(entries))
        f.write("  </Collection>\n</VTKFile>\n")


if __name__ == "__main__":
    main()
