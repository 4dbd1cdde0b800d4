#!/usr/bin/env python3
"""The hopper of cases/outlets/wedge_two_slots, written to meshes/wedge.stl: a plane wedge hopper 14 cm long
whose bottom strip (2 cm wide, at z = 0) holds two slots along its length, 4 cm and 2.5 cm long, with
3 cm of solid strip between them; the wedge walls (30 deg from vertical) rise to a bin 8 cm wide with
vertical walls to z = 18 cm, closed at y = +-7 cm by end walls. `mlcg check` finds both slots as outlets.

    python3 cases/outlets/wedge_two_slots/make_mesh.py

The mesh is conforming: the wedge walls' lower edges are split where the strip's pieces end, so that a
slot's rim is an edge loop of the mesh (each edge with one triangle), found as an outlet.
"""
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from plates import quad, write_stl  # noqa: E402

W0 = 0.02            # strip (and slot) width [m]
B = 0.08             # bin width [m]
H = 0.18             # top of the walls [m]
HALF_ANGLE = 30.0    # wedge walls from vertical [deg]
# the strip along y, cut at these y; the pieces marked True are slots (left open)
CUTS = [-0.07, -0.06, -0.02, 0.01, 0.035, 0.07]
SLOT = [False, True, False, True, False]

ZW = (B - W0) / 2 / math.tan(math.radians(HALF_ANGLE))  # top of the wedge [m]


def hopper():
    w, b, l = W0 / 2, B / 2, CUTS[-1]
    tris = []
    for y0, y1, slot in zip(CUTS[:-1], CUTS[1:], SLOT):
        if not slot:
            tris += quad([-w, y0, 0.0], [w, y0, 0.0], [w, y1, 0.0], [-w, y1, 0.0])
        for s in (1.0, -1.0):  # the wedge walls over this piece: their lower edge is the piece's edge
            tris += quad([s * w, y0, 0.0], [s * w, y1, 0.0], [s * b, y1, ZW], [s * b, y0, ZW])
    for s in (1.0, -1.0):
        tris += quad([s * b, -l, ZW], [s * b, l, ZW], [s * b, l, H], [s * b, -l, H])      # bin walls x = +-B/2
        tris += quad([-w, s * l, 0.0], [w, s * l, 0.0], [b, s * l, ZW], [-b, s * l, ZW])  # end walls y = +-l
        tris += quad([-b, s * l, ZW], [b, s * l, ZW], [b, s * l, H], [-b, s * l, H])
    return tris


if __name__ == "__main__":
    write_stl(os.path.join(HERE, "meshes", "wedge.stl"), hopper())
    print(f"wedge top z = {ZW:.5f} m")
