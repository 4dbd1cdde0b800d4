#!/usr/bin/env python3
"""The hopper of cases/outlets/offcentre_stl, written to meshes/hopper.stl: an oblique pyramid from an
8 cm square at z = 5 cm down to a 2.5 cm square outlet at z = 0 centred at x = +2 cm (its +x face 8.5 deg
from vertical, its -x face 43.5 deg, the y faces 28.8 deg), under a square bin with vertical walls to
z = 15 cm. The outlet is only in the mesh: `mlcg check` finds it as the rim of the mesh's lower edge loop.

    python3 cases/outlets/offcentre_stl/make_mesh.py
"""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from plates import quad, write_stl  # noqa: E402

TOP = 0.04           # half width of the bin [m]
ZP = 0.05            # top of the pyramid [m]
H = 0.15             # top of the bin walls [m]
XO, D0 = 0.02, 0.025  # outlet centre (x) and side [m]


def hopper():
    lo = [[XO - D0 / 2, -D0 / 2], [XO + D0 / 2, -D0 / 2], [XO + D0 / 2, D0 / 2], [XO - D0 / 2, D0 / 2]]
    hi = [[-TOP, -TOP], [TOP, -TOP], [TOP, TOP], [-TOP, TOP]]
    tris = []
    for k in range(4):
        n = (k + 1) % 4
        tris += quad(lo[k] + [0.0], lo[n] + [0.0], hi[n] + [ZP], hi[k] + [ZP])   # a pyramid face
        tris += quad(hi[k] + [ZP], hi[n] + [ZP], hi[n] + [H], hi[k] + [H])       # a bin wall
    return tris


if __name__ == "__main__":
    write_stl(os.path.join(HERE, "meshes", "hopper.stl"), hopper())
