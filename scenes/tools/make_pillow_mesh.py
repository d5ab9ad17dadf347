#!/usr/bin/env python3
"""Writes scenes/meshes/pillow.obj: a closed pillow, two 0.5 m x 0.5 m sheets (17 x 17 nodes) sewn along their
border (the border vertices shared, at y = 0.3), the top sheet's interior 1 cm above the seam and the bottom's
1 cm below; outward winding. Used by scenes/pillow.json."""
import os

N, SIZE, GAP, Y0 = 17, 0.5, 0.01, 0.3
x, top, bottom = [], {}, {}
for j in range(N):
    for i in range(N):
        px, pz = -SIZE / 2 + SIZE * i / (N - 1), -SIZE / 2 + SIZE * j / (N - 1)
        border = i in (0, N - 1) or j in (0, N - 1)
        top[(i, j)] = len(x)
        x.append((px, Y0 + (0.0 if border else GAP), pz))
        if border:
            bottom[(i, j)] = top[(i, j)]
        else:
            bottom[(i, j)] = len(x)
            x.append((px, Y0 - GAP, pz))
tris = []
for j in range(N - 1):
    for i in range(N - 1):
        a, b, c, d = (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)
        # Two corner cells would get a triangle of three seam vertices on both sheets: split them along a-d.
        cell = [(a, c, d), (a, d, b)] if (i, j) in ((0, 0), (N - 2, N - 2)) else [(a, c, b), (b, c, d)]
        for f in cell:
            tris.append((top[f[0]], top[f[1]], top[f[2]]))  # normal +y
            tris.append((bottom[f[0]], bottom[f[2]], bottom[f[1]]))  # normal -y
out = os.path.join(os.path.dirname(__file__), "..", "meshes", "pillow.obj")
with open(out, "w") as f:
    f.write("# pillow for scenes/pillow.json, written by scenes/tools/make_pillow_mesh.py\n")
    for p in x:
        f.write("v %.6f %.6f %.6f\n" % p)
    for t in tris:
        f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
