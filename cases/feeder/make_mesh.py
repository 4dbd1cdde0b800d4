#!/usr/bin/env python3
"""Writes the meshes of cases/feeder (ASCII STL, metres): a wedge hopper over a belt feeder.

    python3 make_mesh.py            # from this folder; plain python3, no packages

Geometry (x along the belt, y across it, z up; the hopper's slot centred at the origin):
- meshes/hopper.stl: the wedge hopper of cases/hoppers/wedge_slot (slot W0 x L at z = 0, walls 30 deg
  from vertical up to a 10 cm x 4.5 cm bin), and below the slot down to the belt: a back plate at
  x = -W0/2 and two side skirts at y = +-L/2 running along the belt to its end. The front of the slot
  is open: the hopper's +x wall ends GATE above the belt, and that gap sets the flow.
- meshes/belt.stl: the belt, a flat rectangle at z = -GATE from x = -W0/2 - 5 mm to BELT_END, as wide as
  the skirts (the case gives it a surface velocity along +x). Past BELT_END the particles fall off.
Every triangle's normal points toward the particles.
"""
import importlib.util
import os

# The hopper is cases/hoppers/wedge_slot's: its geometry and STL helpers come from that case's script.
_spec = importlib.util.spec_from_file_location(
    "wedge_slot_mesh", os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "hoppers", "wedge_slot", "make_mesh.py"))
wedge = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(wedge)

W0, L = wedge.W0, wedge.L   # slot width along the belt, slot length = bin depth = the skirts' spacing [m]
GATE = 0.012        # the belt's surface below the slot (the gate's height) [m]
BELT_END = 0.090    # where the belt ends [m]
BELT_START = -W0 / 2 - 0.005


def hopper():
    """The wedge hopper, and below its slot the back plate and the two skirts along the belt."""
    w, l, g = W0 / 2, L / 2, GATE
    walls = wedge.hopper()  # the +x and -x sides (8 triangles), then each end wall y = +-L/2 (4 each)
    tris = walls[:8]
    for k, s in enumerate((1.0, -1.0)):  # each skirt after its end wall: the order the measured runs used
        tris += walls[8 + 4 * k:12 + 4 * k]
        tris += wedge.quad([-w, s * l, -g], [BELT_END, s * l, -g], [BELT_END, s * l, 0.0], [-w, s * l, 0.0],
                           [0.0, -s, 0.0])
    tris += wedge.quad([-w, -l, -g], [-w, l, -g], [-w, l, 0.0], [-w, -l, 0.0], [1.0, 0.0, 0.0])  # the back plate
    return tris


def belt():
    l, g = L / 2, GATE
    return wedge.quad([BELT_START, -l, -g], [BELT_END, -l, -g], [BELT_END, l, -g], [BELT_START, l, -g], [0.0, 0.0, 1.0])


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    os.makedirs(os.path.join(here, "meshes"), exist_ok=True)
    wedge.write_stl(os.path.join(here, "meshes", "hopper.stl"), "hopper", hopper())
    wedge.write_stl(os.path.join(here, "meshes", "belt.stl"), "belt", belt())
    print(f"meshes/hopper.stl, meshes/belt.stl: slot {W0 * 1000:g} x {L * 1000:g} mm, gate {GATE * 1000:g} mm, "
          f"belt to x = {BELT_END:g} m, wedge top z = {wedge.ZW:.5f} m")
