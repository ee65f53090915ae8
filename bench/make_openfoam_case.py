#!/usr/bin/python3
"""Writes a structured N^3 hexahedral block as an OpenFOAM case (polyMesh + one volScalarField), for timing and memory
figures of the OpenFOAM reader (bench/run_openfoam_read.sh; bench/README.md "OpenFOAM reading").

  /usr/bin/python3 bench/make_openfoam_case.py OUT_DIR --n 100 [--binary] [--gzip] [--tensor] [--steps S]

The case: points on the unit cube's (N+1)^3 lattice; internal faces in OpenFOAM's upper-triangular order (by owner,
then neighbour; each normal points from owner to neighbour), then one "walls" patch of the 6 N^2 boundary faces
(normals outward); field 0/p = x + 2y + 3z at the cell centres. ascii writes faces as a faceList, binary as a
faceCompactList (as OpenFOAM does), labels 32-bit, scalars 64-bit, little-endian. --gzip writes every file as NAME.gz.
--tensor adds 0/T, a volTensorField (9 values a cell: a field file larger than the mesh's own files, where holding a
file's text whole shows in the peak memory).
--steps S writes S time directories 0, 1, ..., S-1 on the one constant mesh (no time-directory polyMesh), each with
its p = (1 + k / 10) (x + 2y + 3z) and U = (x, y, z) (1 + k / 10) at the cell centres: a series whose steps have one
mesh, for the step-switch figures (bench/run_openfoam_switch.sh).
Pure python3 + numpy (Debian python3-numpy: run it with /usr/bin/python3).
"""
import argparse
import gzip
import io
import os

import numpy as np


def header(fmt, cls, location, obj):
    return ('FoamFile\n{\n    version     2.0;\n    format      %s;\n    arch        "LSB;label=32;scalar=64";\n'
            '    class       %s;\n    location    "%s";\n    object      %s;\n}\n'
            '// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //\n\n' % (fmt, cls, location, obj))


def ascii_rows(array, fmt):
    out = io.StringIO()
    np.savetxt(out, array, fmt=fmt)
    return out.getvalue()


class Writer:
    def __init__(self, root, binary, gz):
        self.root, self.binary, self.gz = root, binary, gz
        self.fmt = 'binary' if binary else 'ascii'

    def write(self, rel, data):
        path = os.path.join(self.root, rel) + ('.gz' if self.gz else '')
        os.makedirs(os.path.dirname(path), exist_ok=True)
        data = data.encode() if isinstance(data, str) else data
        if self.gz:
            with gzip.open(path, 'wb', compresslevel=6) as f:
                f.write(data)
        else:
            with open(path, 'wb') as f:
                f.write(data)

    def scalar_list(self, values, width):
        """values: (n, width) float64 (width 1: scalars)."""
        n = values.shape[0]
        if self.binary:
            return b'%d\n(' % n + np.ascontiguousarray(values, '<f8').tobytes() + b')\n'
        fmt = '%.9g' if width == 1 else '(' + ' '.join(['%.9g'] * width) + ')'
        return ('%d\n(\n' % n + ascii_rows(values if width > 1 else values[:, 0], fmt) + ')\n').encode()

    def label_list(self, labels):
        n = labels.shape[0]
        if self.binary:
            return b'%d\n(' % n + np.ascontiguousarray(labels, '<i4').tobytes() + b')\n'
        return ('%d\n(\n' % n + ascii_rows(labels, '%d') + ')\n').encode()


def mesh(n):
    m = n + 1
    i, j, k = np.meshgrid(np.arange(m), np.arange(m), np.arange(m), indexing='ij')
    points = np.stack([i.ravel(order='F'), j.ravel(order='F'), k.ravel(order='F')], axis=1) / float(n)

    def p(a, b, c):
        return a + m * b + m * m * c

    def cell(a, b, c):
        return a + n * b + n * n * c

    faces, owner, neighbour = [], [], []
    # Internal faces with +x, +y, +z normals (owner on the low side).
    a, b, c = [x.ravel() for x in np.meshgrid(np.arange(n - 1), np.arange(n), np.arange(n), indexing='ij')]
    faces.append(np.stack([p(a + 1, b, c), p(a + 1, b + 1, c), p(a + 1, b + 1, c + 1), p(a + 1, b, c + 1)], 1))
    owner.append(cell(a, b, c))
    neighbour.append(cell(a + 1, b, c))
    a, b, c = [x.ravel() for x in np.meshgrid(np.arange(n), np.arange(n - 1), np.arange(n), indexing='ij')]
    faces.append(np.stack([p(a, b + 1, c), p(a, b + 1, c + 1), p(a + 1, b + 1, c + 1), p(a + 1, b + 1, c)], 1))
    owner.append(cell(a, b, c))
    neighbour.append(cell(a, b + 1, c))
    a, b, c = [x.ravel() for x in np.meshgrid(np.arange(n), np.arange(n), np.arange(n - 1), indexing='ij')]
    faces.append(np.stack([p(a, b, c + 1), p(a + 1, b, c + 1), p(a + 1, b + 1, c + 1), p(a, b + 1, c + 1)], 1))
    owner.append(cell(a, b, c))
    neighbour.append(cell(a, b, c + 1))
    faces, owner, neighbour = np.concatenate(faces), np.concatenate(owner), np.concatenate(neighbour)
    order = np.lexsort((neighbour, owner))
    faces, owner, neighbour = faces[order], owner[order], neighbour[order]
    # Boundary faces, outward normals.
    u, v = [x.ravel() for x in np.meshgrid(np.arange(n), np.arange(n), indexing='ij')]
    z0, zn = np.zeros_like(u), np.full_like(u, n)
    bf, bo = [], []
    bf.append(np.stack([p(z0, u, v), p(z0, u, v + 1), p(z0, u + 1, v + 1), p(z0, u + 1, v)], 1))  # x = 0, -x
    bo.append(cell(z0, u, v))
    bf.append(np.stack([p(zn, u, v), p(zn, u + 1, v), p(zn, u + 1, v + 1), p(zn, u, v + 1)], 1))  # x = 1, +x
    bo.append(cell(zn - 1, u, v))
    bf.append(np.stack([p(u, z0, v), p(u + 1, z0, v), p(u + 1, z0, v + 1), p(u, z0, v + 1)], 1))  # y = 0, -y
    bo.append(cell(u, z0, v))
    bf.append(np.stack([p(u, zn, v), p(u, zn, v + 1), p(u + 1, zn, v + 1), p(u + 1, zn, v)], 1))  # y = 1, +y
    bo.append(cell(u, zn - 1, v))
    bf.append(np.stack([p(u, v, z0), p(u, v + 1, z0), p(u + 1, v + 1, z0), p(u + 1, v, z0)], 1))  # z = 0, -z
    bo.append(cell(u, v, z0))
    bf.append(np.stack([p(u, v, zn), p(u + 1, v, zn), p(u + 1, v + 1, zn), p(u, v + 1, zn)], 1))  # z = 1, +z
    bo.append(cell(u, v, zn - 1))
    n_internal = faces.shape[0]
    faces = np.concatenate([faces] + bf)
    owner = np.concatenate([owner] + bo)
    a, b, c = [x.ravel(order='F') for x in np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing='ij')]
    centres = (np.stack([a, b, c], 1) + 0.5) / n
    field = centres[:, 0] + 2 * centres[:, 1] + 3 * centres[:, 2]
    return points, faces, owner, neighbour, n_internal, field, centres


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('out')
    ap.add_argument('--n', type=int, default=100, help='cells per edge (N^3 cells)')
    ap.add_argument('--binary', action='store_true')
    ap.add_argument('--gzip', action='store_true')
    ap.add_argument('--tensor', action='store_true', help='also write 0/T, a volTensorField')
    ap.add_argument('--steps', type=int, default=1, help='time directories 0..S-1 on the one mesh')
    args = ap.parse_args()
    n = args.n
    points, faces, owner, neighbour, n_internal, field, centres = mesh(n)
    w = Writer(args.out, args.binary, args.gzip)
    pm = 'constant/polyMesh'
    w.write(pm + '/points', header(w.fmt, 'vectorField', pm, 'points').encode() + w.scalar_list(points, 3))
    if args.binary:
        offsets = np.arange(faces.shape[0] + 1, dtype=np.int64) * 4
        body = w.label_list(offsets) + b'\n' + w.label_list(faces.ravel())
        w.write(pm + '/faces', header(w.fmt, 'faceCompactList', pm, 'faces').encode() + body)
    else:
        body = '%d\n(\n' % faces.shape[0] + ascii_rows(faces, '4(%d %d %d %d)') + ')\n'
        w.write(pm + '/faces', header(w.fmt, 'faceList', pm, 'faces') + body)
    w.write(pm + '/owner', header(w.fmt, 'labelList', pm, 'owner').encode() + w.label_list(owner))
    w.write(pm + '/neighbour', header(w.fmt, 'labelList', pm, 'neighbour').encode() + w.label_list(neighbour))
    boundary = ('1\n(\n    walls\n    {\n        type            wall;\n        nFaces          %d;\n'
                '        startFace       %d;\n    }\n)\n' % (6 * n * n, n_internal))
    w.write(pm + '/boundary', header('ascii', 'polyBoundaryMesh', pm, 'boundary') + boundary)
    walls = b';\n\nboundaryField\n{\n    walls\n    {\n        type            zeroGradient;\n    }\n}\n'
    for k in range(args.steps):
        t, scale = str(k), 1.0 + k / 10.0
        p = (header(w.fmt, 'volScalarField', t, 'p') + 'dimensions      [0 2 -2 0 0 0 0];\n\ninternalField   '
             'nonuniform List<scalar> ').encode() + w.scalar_list(scale * field[:, None], 1) + walls
        w.write(t + '/p', p)
        if args.steps > 1:
            u = (header(w.fmt, 'volVectorField', t, 'U') + 'dimensions      [0 1 -1 0 0 0 0];\n\ninternalField   '
                 'nonuniform List<vector> ').encode() + w.scalar_list(scale * centres, 3) + walls
            w.write(t + '/U', u)
    if args.tensor:
        t = field[:, None] * (1.0 + np.arange(9)[None, :] / 7.0)
        tt = (header(w.fmt, 'volTensorField', '0', 'T') + 'dimensions      [0 0 0 0 0 0 0];\n\ninternalField   '
              'nonuniform List<tensor> ').encode() + w.scalar_list(t, 9) + \
            b';\n\nboundaryField\n{\n    walls\n    {\n        type            zeroGradient;\n    }\n}\n'
        w.write('0/T', tt)
    os.makedirs(os.path.join(args.out, 'system'), exist_ok=True)
    with open(os.path.join(args.out, 'system', 'controlDict'), 'w') as f:
        f.write(header('ascii', 'dictionary', 'system', 'controlDict') + 'application icoFoam;\n')
    open(os.path.join(args.out, os.path.basename(os.path.normpath(args.out)) + '.foam'), 'w').close()


if __name__ == '__main__':
    main()
