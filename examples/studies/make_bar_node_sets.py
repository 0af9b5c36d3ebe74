#!/usr/bin/env python3
"""Writes the grip node sets of bar_quadrature.yaml for each grid it studies: the points of the
first and last three x-layers (one horizon, m = 3.015) of the PdQuickGrid bar of NX x NY x NZ
points, numbered as PdQuickGrid numbers them (x fastest, 1-based)."""

LAYERS = 3
for nx, ny, nz in ((20, 4, 4), (30, 6, 6), (40, 8, 8), (50, 10, 10), (60, 12, 12)):
    for name, layers in (("left", range(LAYERS)), ("right", range(nx - LAYERS, nx))):
        ids = [1 + i + nx * (j + ny * k) for k in range(nz) for j in range(ny) for i in layers]
        with open(f"bar_{nx}_{name}.txt", "w") as f:
            f.write("\n".join(map(str, sorted(ids))) + "\n")
