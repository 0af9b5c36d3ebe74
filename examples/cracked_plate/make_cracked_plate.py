#!/usr/bin/env python3
"""Writes the point cloud of examples/cracked_plate/cracked_plate.yaml (standard library only).

Macek & Silling's brittle center-cracked plate ("Peridynamics via finite element analysis",
2007): an aluminium plate 100 mm wide (x), 300 mm long (y) and 10 mm thick (z), with a 50 mm
through crack across its middle (the deck's bond filter, at y = 150 mm from x = 25 to 75 mm).
Points sit at the centres of cells of the given spacing in the plane. The three rows of cells at each end (one horizon, 3 spacings) are
the grips: block 1 at the bottom (held), block 3 at the top (pulled); the rest is block 2.

Usage: make_cracked_plate.py [SPACING_MM] [--solid] (default 2). Without --solid the plate is
one layer of points through its thickness, for the plane-stress deck cracked_plate.yaml
(7,500 points at 2 mm); with --solid, cubic cells through the thickness as well, for
cracked_plate_solid.yaml (37,500 points at 2 mm, the paper's grid), in files named
cracked_plate_solid*.txt. The spacing must divide the plate into an even number of rows, so that the crack plane
lies between two rows. Output beside this script: cracked_plate.txt (`x y z block_id volume`,
metres), the grips' node sets cracked_plate_bottom.txt and cracked_plate_top.txt and the node
set of every point, cracked_plate_all.txt (1-based point ids).
"""
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
WIDTH, LENGTH, THICKNESS = 0.100, 0.300, 0.010
GRIP_ROWS = 3


def main():
    args = sys.argv[1:]
    solid = "--solid" in args
    args = [a for a in args if a != "--solid"]
    spacing = float(args[0]) * 1e-3 if args else 2.0e-3
    nx, ny, nz = (round(d / spacing) for d in (WIDTH, LENGTH, THICKNESS))
    if not solid:
        nz = 1
    divides = abs(nx * spacing - WIDTH) < 1e-9 and abs(ny * spacing - LENGTH) < 1e-9
    if min(nx, ny, nz) < 1 or not divides or ny % 2:
        sys.exit(f"a spacing of {spacing * 1e3} mm does not divide the plate's 100 × 300 mm into an even number of rows")
    dz = THICKNESS / nz
    volume = spacing * spacing * dz
    lines, bottom, top = [], [], []
    for k in range(nz):
        for j in range(ny):
            block = 1 if j < GRIP_ROWS else 3 if j >= ny - GRIP_ROWS else 2
            for i in range(nx):
                x, y, z = (i + 0.5) * spacing, (j + 0.5) * spacing, (k + 0.5) * dz
                lines.append(f"{x:.9e} {y:.9e} {z:.9e} {block} {volume:.9e}")
                {1: bottom, 3: top}.get(block, []).append(str(len(lines)))
    name = "cracked_plate_solid" if solid else "cracked_plate"
    (HERE / f"{name}.txt").write_text("\n".join(lines) + "\n")
    (HERE / f"{name}_bottom.txt").write_text(" ".join(bottom) + "\n")
    (HERE / f"{name}_top.txt").write_text(" ".join(top) + "\n")
    every = " ".join(str(i + 1) for i in range(len(lines)))
    (HERE / f"{name}_all.txt").write_text(every + "\n")
    print(f"{name}.txt: {len(lines)} points ({nx} x {ny} x {nz}), spacing {spacing * 1e3} mm")


main()
