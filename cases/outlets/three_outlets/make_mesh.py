#!/usr/bin/env python3
"""The floor of cases/outlets/three_outlets: a flat plate 32 x 5 cm at z = 0 of 2.5 mm squares with three
square holes in a row, 11 cm apart: 3 cm at x = -11 cm, 2 cm at x = 0 and 2.5 cm at x = +11 cm, written to
meshes/floor.stl. `mlcg check` finds the three holes as the scene's outlets (each under its lid).

    python3 cases/outlets/three_outlets/make_mesh.py
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from plates import holes, plate, write_stl  # noqa: E402

# cells i along x from -0.16 (128), j along y from -0.025 (20); the holes as cell ranges [i0, i1) x [j0, j1)
HOLES = [(14, 26, 4, 16),    # 3 cm square at x = -0.11
         (60, 68, 6, 14),    # 2 cm square at x = 0
         (103, 113, 5, 15)]  # 2.5 cm square at x = +0.11


if __name__ == "__main__":
    write_stl(os.path.join(HERE, "meshes", "floor.stl"),
              plate((-0.16, -0.025, 0.0), (1, 0, 0), (0, 1, 0), 128, 20, 0.0025, holes(HOLES)))
