#!/usr/bin/env python3
"""The meshes of cases/outlets/side_outlet, of 5 mm squares: meshes/floor.stl, the bin's floor 12 x 6 cm at
z = 0, and meshes/wall.stl, its +x wall at x = 0.06 m, 6 cm wide and 17 cm high, with a 3 cm square hole
5 mm above the floor. `mlcg check` finds the hole as the scene's outlet, the flow leaving along +x.

    python3 cases/outlets/side_outlet/make_mesh.py
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from plates import plate, write_stl  # noqa: E402

if __name__ == "__main__":
    write_stl(os.path.join(HERE, "meshes", "floor.stl"), plate((-0.06, -0.03, 0.0), (1, 0, 0), (0, 1, 0), 24, 12, 0.005))
    # i along y from -0.03 (12 cells), j along z from 0 (34 cells); the hole: y in [-0.015, 0.015], z in [0.005, 0.035]
    write_stl(os.path.join(HERE, "meshes", "wall.stl"),
              plate((0.06, -0.03, 0.0), (0, 1, 0), (0, 0, 1), 12, 34, 0.005, lambda i, j: 3 <= i < 9 and 1 <= j < 7))
