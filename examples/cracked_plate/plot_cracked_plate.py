#!/usr/bin/env python3
"""Reads cracked_plate.e and writes the curves of the center-cracked plate: far-field stress
and crack length against the grips' displacement, as
cracked_plate_curve.csv and cracked_plate.png (needs netCDF4 and matplotlib:
`pip install netCDF4 matplotlib`).

Far-field stress: the top grip's reaction (global Top_Reaction_ForceY, negated) over the section
W·t = 0.1 m × 0.01 m. Grip displacement: the prescribed 0.6 mm·t. Crack length 2a: between
the outermost points, in the two rows of points next to the crack plane y = 150 mm, whose
damage is at least 0.2 (a point the crack has passed lost the bonds that cross the plane, a
third of its bonds or more; the pre-crack's points lost theirs to the bond filter and show no
damage), never less than the pre-crack's 50 mm.

Usage: plot_cracked_plate.py [RESULTS.e] [--expected MPa] (defaults: cracked_plate.e, 72.2).
"""
import csv
import sys
from pathlib import Path

import numpy as np
from netCDF4 import Dataset, chartostring

SECTION = 0.100 * 0.010
PULL = 0.6e-3
PRECRACK = 0.050
CRACK_PLANE_Y = 0.150
DAMAGED = 0.2


def names(variable):
    return [str(name).strip() for name in chartostring(variable[:])]


def point_damage(data, frames, points):
    """Damage of every point at every frame: an element variable, one sphere element per point
    in each block (Peridigm's layout), mapped to its node through the block's connectivity."""
    index = names(data.variables["name_elem_var"]).index("Damage") + 1
    damage = np.zeros((frames, points))
    block = 1
    while f"connect{block}" in data.variables:
        nodes = data.variables[f"connect{block}"][:, 0] - 1
        name = f"vals_elem_var{index}eb{block}"
        if name in data.variables:
            damage[:, nodes] = data.variables[name][:]
        block += 1
    return damage


def main():
    args = sys.argv[1:]
    expected = 72.2
    if "--expected" in args:
        i = args.index("--expected")
        expected = float(args[i + 1])
        del args[i : i + 2]
    path = Path(args[0] if args else "cracked_plate.e")
    data = Dataset(path)
    times = data.variables["time_whole"][:]
    global_names = names(data.variables["name_glo_var"])
    # The grip's reaction is the body's force on it: along −y while the grip pulls along +y.
    reaction = -data.variables["vals_glo_var"][:, global_names.index("Top_Reaction_ForceY")]
    x, y = data.variables["coordx"][:], data.variables["coordy"][:]
    damage = point_damage(data, len(times), len(x))
    row_gap = np.min(np.abs(y - CRACK_PLANE_Y))
    beside = np.abs(np.abs(y - CRACK_PLANE_Y) - row_gap) < 1e-9
    spacing = 2.0 * row_gap
    rows = []
    for frame, t in enumerate(times):
        cracked = x[beside & (damage[frame, :] >= DAMAGED)]
        length = PRECRACK
        if cracked.size:
            length = max(length, cracked.max() - cracked.min() + spacing)
        rows.append((t, PULL * t * 1e3, reaction[frame] / SECTION / 1e6, length * 1e3))
    out = path.with_name(path.stem + "_curve.csv")
    with open(out, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["Time", "Grip_Displacement_mm", "Far_Field_Stress_MPa", "Crack_Length_mm"])
        writer.writerows(rows)
    peak = max(r[2] for r in rows)
    print(f"{out}: peak far-field stress {peak:.2f} MPa, handbook {expected} MPa ({100 * (peak / expected - 1):+.1f} %)")
    plot(path.with_suffix(".png"), rows, expected)


def plot(png, rows, expected):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    _, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.plot([r[1] for r in rows], [r[2] for r in rows], "o-", ms=3, label="peridyn")
    left.axhline(expected, color="k", ls="--", lw=1, label=f"handbook {expected} MPa")
    left.set_xlabel("grip displacement (mm)")
    left.set_ylabel("far-field stress (MPa)")
    left.legend()
    right.plot([r[1] for r in rows], [r[3] for r in rows], "o-", ms=3)
    right.set_xlabel("grip displacement (mm)")
    right.set_ylabel("crack length 2a (mm)")
    plt.tight_layout()
    plt.savefig(png, dpi=120)
    print(f"{png}")


main()
