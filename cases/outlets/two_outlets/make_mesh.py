#!/usr/bin/env python3
"""The floor of cases/outlets/two_outlets: a flat plate 26 x 5 cm at z = 0 of 5 mm squares (two triangles
each) with two square holes, 3 cm at x = -7 cm and 2 cm at x = +7 cm, written as ASCII STL to
meshes/floor.stl. `mlcg check` finds both holes as the scene's outlets (each under its lid).

    python3 cases/outlets/two_outlets/make_mesh.py
"""
import os

H = 0.005                  # cell [m]
X0, NX = -0.13, 52         # x from -0.13 to 0.13
Y0, NY = -0.025, 10        # y from -0.025 to 0.025
HOLES = [(9, 15, 2, 8),    # 3 cm square at x = -0.07: cells i in [9, 15), j in [2, 8)
         (38, 42, 3, 7)]   # 2 cm square at x = +0.07


def in_hole(i, j):
    return any(i0 <= i < i1 and j0 <= j < j1 for i0, i1, j0, j1 in HOLES)


def main():
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "meshes", "floor.stl")
    lines = ["solid floor"]
    for i in range(NX):
        for j in range(NY):
            if in_hole(i, j):
                continue
            x, y = X0 + i * H, Y0 + j * H
            a, b, c, d = (x, y), (x + H, y), (x + H, y + H), (x, y + H)
            for tri in ((a, b, c), (a, c, d)):
                lines += ["facet normal 0 0 1", "outer loop"]
                lines += ["vertex %.6f %.6f 0" % p for p in tri]
                lines += ["endloop", "endfacet"]
    lines.append("endsolid floor")
    tmp = out + ".tmp"
    with open(tmp, "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(tmp, out)


if __name__ == "__main__":
    main()
