#!/usr/bin/env python3
"""Writes meshes/wedge.stl (ASCII, metres) for cases/hoppers/wedge_slot: a plane wedge hopper with a
slot outlet under a rectangular bin.

    python3 make_mesh.py            # from this folder; plain python3, no packages

Geometry (x across the slot, y along it, z up; the slot centred at the origin):
- slot: x in [-W0/2, W0/2], y in [-L/2, L/2] at z = 0 (left open: the case's lid closes it);
- two wedge walls from x = +-W0/2 at z = 0 up to x = +-B/2 at z = zw, HALF_ANGLE from vertical;
- two vertical bin walls x = +-B/2 from zw to H;
- two vertical end walls y = +-L/2 spanning the wedge and the bin (so the slot is as long as the bin).
Every triangle's normal points into the hopper, toward the particles.
"""
import math
import os

W0 = 0.030          # slot width [m]
L = 0.045           # slot length = bin depth [m]
B = 0.100           # bin width [m]
H = 0.200           # top of the walls [m]
HALF_ANGLE = 30.0   # wedge wall angle from vertical [deg]

ZW = (B - W0) / 2 / math.tan(math.radians(HALF_ANGLE))  # top of the wedge [m]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def quad(a, b, c, d, inward):
    """Two triangles of the planar quad a-b-c-d, wound so that their normal is along `inward`."""
    tris = []
    for t in ((a, b, c), (a, c, d)):
        n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
        if sum(n[i] * inward[i] for i in range(3)) < 0:
            t = (t[0], t[2], t[1])
        tris.append(t)
    return tris


def hopper():
    w, b, l = W0 / 2, B / 2, L / 2
    tris = []
    for s in (1.0, -1.0):  # the +x and -x sides
        inward_wedge = unit([-s * math.cos(math.radians(HALF_ANGLE)), 0.0, math.sin(math.radians(HALF_ANGLE))])
        tris += quad([s * w, -l, 0.0], [s * w, l, 0.0], [s * b, l, ZW], [s * b, -l, ZW], inward_wedge)
        tris += quad([s * b, -l, ZW], [s * b, l, ZW], [s * b, l, H], [s * b, -l, H], [-s, 0.0, 0.0])
    for s in (1.0, -1.0):  # the end walls y = +-L/2: the wedge's trapezoid and the bin's rectangle
        inward = [0.0, -s, 0.0]
        tris += quad([-w, s * l, 0.0], [w, s * l, 0.0], [b, s * l, ZW], [-b, s * l, ZW], inward)
        tris += quad([-b, s * l, ZW], [b, s * l, ZW], [b, s * l, H], [-b, s * l, H], inward)
    return tris


def write_stl(path, name, tris):
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            n = unit(cross(sub(t[1], t[0]), sub(t[2], t[0])))
            f.write("  facet normal {:.6g} {:.6g} {:.6g}\n    outer loop\n".format(*n))
            for v in t:
                f.write("      vertex {:.9g} {:.9g} {:.9g}\n".format(*v))
            f.write("    endloop\n  endfacet\n")
        f.write(f"endsolid {name}\n")


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    os.makedirs(os.path.join(here, "meshes"), exist_ok=True)
    out = os.path.join(here, "meshes", "wedge.stl")
    tris = hopper()
    write_stl(out, "wedge", tris)
    print(f"{out}: {len(tris)} triangles; slot {W0 * 1000:g} x {L * 1000:g} mm, wedge top z = {ZW:.5f} m")
