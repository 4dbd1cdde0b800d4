#!/usr/bin/env python3
"""The floor of cases/outlets/two_outlets: a flat plate 26 x 5 cm at z = 0 of 5 mm squares with two square
holes, 3 cm at x = -7 cm and 2 cm at x = +7 cm, written to meshes/floor.stl. `mlcg check` finds both holes
as the scene's outlets (each under its lid).

    python3 cases/outlets/two_outlets/make_mesh.py
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from plates import holes, plate, write_stl  # noqa: E402

# cells i along x from -0.13 (52), j along y from -0.025 (10); the holes as cell ranges [i0, i1) x [j0, j1)
HOLES = [(9, 15, 2, 8),    # 3 cm square at x = -0.07
         (38, 42, 3, 7)]   # 2 cm square at x = +0.07


if __name__ == "__main__":
    write_stl(os.path.join(HERE, "meshes", "floor.stl"),
              plate((-0.13, -0.025, 0.0), (1, 0, 0), (0, 1, 0), 52, 10, 0.005, holes(HOLES)))
