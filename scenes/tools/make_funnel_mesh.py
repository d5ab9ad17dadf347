#!/usr/bin/env python3
"""Writes scenes/meshes/funnel.obj: an open funnel (a cone from radius 0.35 m at y = 0.5 down to 0.07 m at
y = 0.15, then a spout cylinder down to y = 0), 48 segments, used by scenes/funnel.json."""
import math, os

SEG = 48
RINGS = [(0.35, 0.5), (0.28, 0.43), (0.21, 0.36), (0.14, 0.29), (0.07, 0.15), (0.07, 0.075), (0.07, 0.0)]
out = os.path.join(os.path.dirname(__file__), "..", "meshes", "funnel.obj")
with open(out, "w") as f:
    f.write("# funnel for scenes/funnel.json, written by scenes/tools/make_funnel_mesh.py\n")
    for r, y in RINGS:
        for k in range(SEG):
            a = 2 * math.pi * k / SEG
            f.write("v %.6f %.6f %.6f\n" % (r * math.cos(a), y, r * math.sin(a)))
    for j in range(len(RINGS) - 1):
        for k in range(SEG):
            a, b = j * SEG + k + 1, j * SEG + (k + 1) % SEG + 1
            c, d = a + SEG, b + SEG
            f.write("f %d %d %d\nf %d %d %d\n" % (a, b, d, a, d, c))
