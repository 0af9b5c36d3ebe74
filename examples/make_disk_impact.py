#!/usr/bin/env python3
"""Writes the point cloud of examples/disk_impact.yaml (standard library only).

Silling & Askari's brittle-disk impact: a glass-like disk, 74 mm across and 2.5 mm thick
(block 1), and a steel sphere 10 mm across (block 2) 1 mm above its centre. Points sit on a
1 mm square grid in the plane, three layers through the disk's thickness, and on a 1 mm cubic
grid inside the sphere. Output: disk_impact.txt (`x y z block_id volume`, metres) and
disk_impact_ball_node_set.txt (1-based ids of the sphere's points).
"""
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
SPACING = 1.0e-3
DISK_RADIUS = 37.0e-3
THICKNESS = 2.5e-3
LAYERS = 3
BALL_RADIUS = 5.0e-3
GAP = 1.0e-3

rows = []
dz = THICKNESS / LAYERS
n = int(DISK_RADIUS / SPACING) + 1
for k in range(LAYERS):
    z = -THICKNESS / 2 + (k + 0.5) * dz
    for j in range(-n, n + 1):
        for i in range(-n, n + 1):
            x, y = i * SPACING, j * SPACING
            if x * x + y * y <= DISK_RADIUS * DISK_RADIUS:
                rows.append((x, y, z, 1, SPACING * SPACING * dz))

ball = []
m = int(BALL_RADIUS / SPACING)
centre = THICKNESS / 2 + GAP + BALL_RADIUS
for k in range(-m, m + 1):
    for j in range(-m, m + 1):
        for i in range(-m, m + 1):
            x, y, z = (i + 0.5) * SPACING, (j + 0.5) * SPACING, (k + 0.5) * SPACING
            if x * x + y * y + z * z <= BALL_RADIUS * BALL_RADIUS:
                ball.append(len(rows) + 1)
                rows.append((x, y, centre + z, 2, SPACING ** 3))

with open(HERE / "disk_impact.txt", "w") as f:
    f.write("# x y z block_id volume (m, m^3) -- written by make_disk_impact.py\n")
    for x, y, z, b, v in rows:
        f.write(f"{x:.6g} {y:.6g} {z:.6g} {b} {v:.6g}\n")
with open(HERE / "disk_impact_ball_node_set.txt", "w") as f:
    f.write("# points of the steel ball (1-based ids in disk_impact.txt)\n")
    for start in range(0, len(ball), 20):
        f.write(" ".join(map(str, ball[start:start + 20])) + "\n")
print(f"{len(rows)} points, {len(ball)} in the ball")
