#!/usr/bin/env python3
"""Writes meshes/drum.stl (ASCII, metres) for cases/drum's LIGGGHTS input: the drum of reference.toml as a
closed triangle mesh, which LIGGGHTS-PUBLIC 3.8 needs to turn a wall (it has no analytic cylinder that
rotates). The cylinder, radius R about the y axis from y = -L/2 to L/2, is a prism of N_SIDES flat faces
through points on the circle (its flats lie R cos(pi / N_SIDES) = 0.99946 R from the axis), closed by two
fans; every triangle's normal points into the drum, toward the particles.

    python3 cases/drum/make_mesh.py     # plain python3, no packages
"""
import math
import os

R = 0.04        # drum radius [m], as reference.toml's cylinder 'drum'
L = 0.025       # drum length along y [m]
N_SIDES = 96


def facet(out, a, b, c, inside):
    """One triangle; its vertex order is flipped if needed so that the normal points toward `inside`."""
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
    centre = [(a[i] + b[i] + c[i]) / 3.0 for i in range(3)]
    if sum(n[i] * (inside[i] - centre[i]) for i in range(3)) < 0.0:
        b, c = c, b
        n = [-x for x in n]
    norm = math.sqrt(sum(x * x for x in n))
    out.append("  facet normal %.9e %.9e %.9e\n    outer loop\n" % tuple(x / norm for x in n))
    for p in (a, b, c):
        out.append("      vertex %.9e %.9e %.9e\n" % p)
    out.append("    endloop\n  endfacet\n")


def main():
    out = ["solid drum\n"]
    ring = [(R * math.cos(2 * math.pi * k / N_SIDES), R * math.sin(2 * math.pi * k / N_SIDES)) for k in range(N_SIDES)]
    y0, y1 = -L / 2, L / 2
    for k in range(N_SIDES):
        (x0, z0), (x1, z1) = ring[k], ring[(k + 1) % N_SIDES]
        inside = (0.0, 0.0, 0.0)
        facet(out, (x0, y0, z0), (x1, y0, z1), (x1, y1, z1), inside)
        facet(out, (x0, y0, z0), (x1, y1, z1), (x0, y1, z0), inside)
        facet(out, (0.0, y0, 0.0), (x0, y0, z0), (x1, y0, z1), (0.0, 0.0, 0.0))  # front end
        facet(out, (0.0, y1, 0.0), (x1, y1, z1), (x0, y1, z0), (0.0, 0.0, 0.0))  # back end
    out.append("endsolid drum\n")
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "meshes", "drum.stl")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.writelines(out)
    print("wrote %s: %d triangles" % (path, 4 * N_SIDES))


if __name__ == "__main__":
    main()
