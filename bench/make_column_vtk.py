#!/usr/bin/env python3
"""A column of 2 x 2 x N hexahedra (legacy .vtk structured points, a smooth vertex field `s`) and a camera looking
down it (parallel projection): every ray crosses all N cells. The shape where llvmpipe's loop limit cuts every ray
(shaders/loop_limit_probe.glsl; test ExactGpu.RaysCutByTheDevicesLoopLimitAreTracedOnTheCpu builds the same in memory).
Usage: make_column_vtk.py OUT.vtk CAMERA.json [N=3000]"""
import json
import math
import sys

out, camera = sys.argv[1], sys.argv[2]
n = int(sys.argv[3]) if len(sys.argv) > 3 else 3000
nx, ny, nz = 3, 3, n + 1
with open(out, "w") as f:
    f.write("# vtk DataFile Version 3.0\ncolumn\nASCII\nDATASET STRUCTURED_POINTS\n")
    f.write(f"DIMENSIONS {nx} {ny} {nz}\nORIGIN 0 0 0\nSPACING 1 1 1\nPOINT_DATA {nx * ny * nz}\n")
    f.write("SCALARS s float 1\nLOOKUP_TABLE default\n")
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                f.write("%.7g\n" % (math.sin(0.05 * k) + 0.2 * i + 0.1 * j * k / n))
json.dump({"position": [1, 1, -4], "focal_point": [1, 1, n / 2], "view_up": [0, 1, 0], "view_angle": 30,
           "parallel_projection": True, "parallel_scale": 0.95}, open(camera, "w"))
