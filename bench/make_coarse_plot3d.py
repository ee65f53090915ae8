#!/usr/bin/env python3
"""Coarse curvilinear PLOT3D grids for the leaf-resolution study (issue 25, part 3).

  make_coarse_plot3d.py synthetic OUT_DIR [NI NJ NK]   (default 57 33 25, the combustion chamber's size)
      a warped box grid of nearly uniform cells (no boundary layer to force depth) over [0, 4] x [0, 2] x [0, 1.5]
      with a Density that varies by about 1.5 over a few cells: the case where `ugvr build --error 0` stops at about
      one voxel per cell under the "no two data points per voxel" rule alone;
  make_coarse_plot3d.py bluntfin BLUNTFIN_DIR OUT_DIR [STRIDE=2]
      every STRIDE-th grid line of the blunt fin, its Q solution at the same points.
Both write OUT_DIR/coarsexyz.bin and OUT_DIR/coarseq.bin: big-endian float32, no Fortran records, no IBLANK.
"""
import math
import os
import struct
import sys


def write(dst, dims, coords, q, header=(2.95, 0.0, 2.1e6, 0.0)):
    os.makedirs(dst, exist_ok=True)
    with open(os.path.join(dst, "coarsexyz.bin"), "wb") as f:
        f.write(struct.pack(">3i", *dims) + struct.pack(">%df" % len(coords), *coords))
    with open(os.path.join(dst, "coarseq.bin"), "wb") as f:
        f.write(struct.pack(">3i", *dims) + struct.pack(">4f", *header) + struct.pack(">%df" % len(q), *q))
    print("%s: %d x %d x %d points" % (dst, *dims))


def synthetic(dst, ni, nj, nk):
    pts = []
    for k in range(nk):
        for j in range(nj):
            for i in range(ni):
                u, v, w = i / (ni - 1), j / (nj - 1), k / (nk - 1)
                x = 4 * u + 0.15 * math.sin(math.pi * v) * math.sin(2 * math.pi * w)
                y = 2 * v + 0.2 * math.sin(math.pi * u) * math.sin(math.pi * w)
                z = 1.5 * w + 0.1 * math.sin(2 * math.pi * u)
                pts.append((x, y, z))
    coords = [p[a] for a in range(3) for p in pts]
    dens, mom, energy = [], [], []
    for x, y, z in pts:
        r = math.sqrt((x - 2) ** 2 + (y - 1) ** 2)
        d = 1 + 0.6 * math.sin(3.2 * r) * math.exp(-0.3 * r) + 0.4 * math.tanh(4 * (z - 0.75)) * math.cos(1.3 * x)
        dens.append(d)
        mom.append((d * 0.5, d * 0.1 * math.sin(y), 0.0))
        energy.append(2.5 * d)
    q = dens + [m[0] for m in mom] + [m[1] for m in mom] + [m[2] for m in mom] + energy
    write(dst, (ni, nj, nk), coords, q)


def bluntfin(src, dst, stride):
    def read(path):
        with open(path, "rb") as f:
            return f.read()

    def sub(values, dims):
        ni, nj, nk = dims
        keep = lambda n: sorted(set(list(range(0, n, stride)) + [n - 1]))
        ii, jj, kk = keep(ni), keep(nj), keep(nk)
        return [values[i + ni * (j + nj * k)] for k in kk for j in jj for i in ii], (len(ii), len(jj), len(kk))

    xyz = read(os.path.join(src, "bluntfinxyz.bin"))
    dims = struct.unpack(">3i", xyz[:12])
    n = dims[0] * dims[1] * dims[2]
    values = struct.unpack(">%df" % (3 * n), xyz[12 : 12 + 12 * n])
    coords = []
    for c in range(3):
        s, new_dims = sub(values[c * n : (c + 1) * n], dims)
        coords += s
    qb = read(os.path.join(src, "bluntfinq.bin"))
    header = struct.unpack(">4f", qb[12:28])
    values = struct.unpack(">%df" % (5 * n), qb[28 : 28 + 20 * n])
    q = []
    for c in range(5):
        q += sub(values[c * n : (c + 1) * n], dims)[0]
    write(dst, new_dims, coords, q, header)


if sys.argv[1] == "synthetic":
    dims = [int(a) for a in sys.argv[3:6]] if len(sys.argv) >= 6 else [57, 33, 25]
    synthetic(sys.argv[2], *dims)
else:
    bluntfin(sys.argv[2], sys.argv[3], int(sys.argv[4]) if len(sys.argv) > 4 else 2)
