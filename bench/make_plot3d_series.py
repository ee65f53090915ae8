#!/usr/bin/env python3
"""A PLOT3D time series for the step-switch benchmark (issue 18 [time]): one grid, a solution file per step.

  make_plot3d_series.py OUT_DIR [--n N (100)] [--blocks B (2)] [--steps S (3)]

Writes OUT_DIR/grid.xyz (B blocks of N x N x N/B points, stacked along k: N^3 points in all; a gently warped box so
that the cells are not axis-aligned) and OUT_DIR/sol_0000.q ... one per step (density, momentum, energy varying in
space and per step), multi-block C binary, big-endian float32, no IBLANK: the commonest PLOT3D layout. At N=100 the
grid is 12 MB and each solution 20 MB.
"""
import argparse
import os

import numpy as np


def header(dims):
    return np.array([len(dims)], ">i4").tobytes() + np.array(dims, ">i4").tobytes()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--blocks", type=int, default=2)
    ap.add_argument("--steps", type=int, default=3)
    a = ap.parse_args()
    n, nb = a.n, a.blocks
    if n % nb:
        raise SystemExit("--n must be a multiple of --blocks")
    os.makedirs(a.out, exist_ok=True)
    nk = n // nb
    dims = [(n, n, nk)] * nb
    i = np.linspace(0.0, 1.0, n)
    blocks = []
    for b in range(nb):
        k = np.linspace(b / nb, (b + 1) / nb, nk)
        z, y, x = np.meshgrid(k, i, i, indexing="ij")  # i fastest
        xw = x + 0.05 * np.sin(np.pi * y) * np.sin(np.pi * z)
        yw = y + 0.05 * np.sin(np.pi * x) * np.sin(np.pi * z)
        blocks.append((xw, yw, z))
    with open(os.path.join(a.out, "grid.xyz"), "wb") as f:
        f.write(header(dims))
        for xw, yw, z in blocks:
            for c in (xw, yw, z):
                f.write(c.astype(">f4").tobytes())
    for s in range(a.steps):
        with open(os.path.join(a.out, "sol_%04d.q" % s), "wb") as f:
            f.write(header(dims))
            for xw, yw, z in blocks:
                f.write(np.array([0.5, 0.0, 1e6, float(s)], ">f4").tobytes())
                r = np.sqrt((xw - 0.5 - 0.1 * s) ** 2 + (yw - 0.5) ** 2)
                rho = 1.0 + 0.5 * np.exp(-20 * r * r)
                for c in (rho, rho * 0.3, rho * 0.1 * np.sin(6 * z + s), rho * 0.0, 2.5 + rho):
                    f.write(c.astype(">f4").tobytes())
    print("%s: %d block(s), %d points, %d steps" % (a.out, nb, n * n * n, a.steps))


if __name__ == "__main__":
    main()
