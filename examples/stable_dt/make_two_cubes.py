#!/usr/bin/env python3
"""Writes two_cubes.txt and its node sets for two_cubes.yaml: two 6 x 6 x 6 steel cubes,
spacing 1 cm (cell volume 1e-6 m^3), whose facing layers are 9.5 mm apart along x.
Lines are "x y z block_id volume"; cube 1 (block 1) holds points 1-216, cube 2 points 217-432."""

SPACING = 0.01
GAP = 0.0095  # centre to centre of the facing layers
N = 6

points, sets = [], {1: [], 2: []}
for block, x0 in ((1, 0.5 * SPACING), (2, 0.5 * SPACING + (N - 1) * SPACING + GAP)):
    for k in range(N):
        for j in range(N):
            for i in range(N):
                points.append((x0 + i * SPACING, (j + 0.5) * SPACING, (k + 0.5) * SPACING, block))
                sets[block].append(len(points))

with open("two_cubes.txt", "w") as f:
    f.write("# x y z block_id volume (m, m^3): two 6 x 6 x 6 steel cubes, spacing 1 cm, facing\n")
    f.write("# layers 9.5 mm apart; written by make_two_cubes.py\n")
    for x, y, z, block in points:
        f.write(f"{x:.4f} {y:.4f} {z:.4f} {block} 1.0e-6\n")
for block, name in ((1, "two_cubes_left.txt"), (2, "two_cubes_right.txt")):
    with open(name, "w") as f:
        f.write("\n".join(map(str, sets[block])) + "\n")
