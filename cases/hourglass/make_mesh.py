#!/usr/bin/env python3
"""Writes meshes/hourglass.stl (ASCII, metres) for cases/hourglass: the closed hourglass of the LIGGGHTS-PFM
authors' two-level example (examples/LIGGGHTS/PFM/adaptive_resolution/hourglass, meshes/hourglass_wall.stl,
cgs), rebuilt here from its dimensions; nothing is copied from that file.

    python3 cases/hourglass/make_mesh.py     # plain python3, no packages

Geometry (z up, the neck centred at the origin). Every horizontal section is the same octagon scaled: with
h its distance from the axis to the flats x = +-h and y = +-h, its vertices are (+-h, +-h/3) and (+-h/3, +-h),
and its diagonal flats lie at 2h/(3 sqrt 2) = 0.943 h. (The authors' STL has 12 vertices per ring: the four
extra ones, (+-h/1.5, +-h/1.5), lie on the diagonal flats, so the section is this octagon.)
- neck: a prism h = H_NECK for |z| <= H_NECK (0.4 cm across the flats, 0.4 cm long);
- two cones (one above, one below) with h = |z| from |z| = H_NECK to |z| = H_BULB: flats 45 deg from vertical;
- two prisms h = H_BULB up to the closed ends z = +-Z_END (3 cm across the flats);
- the two ends are closed by flat caps.
The open cross-section of the neck is 0.1244 cm2 (a circle of 3.98 mm). Every triangle's normal points into
the hourglass, toward the particles.
"""
import math
import os

CM = 0.01
H_NECK = 0.2 * CM   # half width of the neck across its flats [m]
H_BULB = 1.5 * CM   # half width of the bulbs across their flats [m]
Z_END = 3.6 * CM    # the closed ends at z = +-Z_END [m]

RINGS = [(-Z_END, H_BULB), (-H_BULB, H_BULB), (-H_NECK, H_NECK),
         (H_NECK, H_NECK), (H_BULB, H_BULB), (Z_END, H_BULB)]


def octagon(h, z):
    """The 8 vertices of the section at height z, counter-clockwise seen from above."""
    s = h / 3.0
    xy = [(h, -s), (h, s), (s, h), (-s, h), (-h, s), (-h, -s), (-s, -h), (s, -h)]
    return [(x, y, z) for x, y in xy]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unit(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def oriented(t, inside):
    """The triangle t wound so that its normal points toward the point `inside`."""
    n = cross(sub(t[1], t[0]), sub(t[2], t[0]))
    c = [sum(v[i] for v in t) / 3.0 for i in range(3)]
    return t if sum(n[i] * (inside[i] - c[i]) for i in range(3)) > 0 else (t[0], t[2], t[1])


def hourglass():
    tris = []
    for (z0, h0), (z1, h1) in zip(RINGS, RINGS[1:]):
        lo, hi = octagon(h0, z0), octagon(h1, z1)
        inside = (0.0, 0.0, 0.5 * (z0 + z1))
        for k in range(8):
            a, b, c, d = lo[k], lo[(k + 1) % 8], hi[(k + 1) % 8], hi[k]
            tris += [oriented((a, b, c), inside), oriented((a, c, d), inside)]
    for z, h in (RINGS[0], RINGS[-1]):  # the caps: a fan around the axis
        ring = octagon(h, z)
        inside = (0.0, 0.0, 0.0)
        for k in range(8):
            tris.append(oriented(((0.0, 0.0, z), ring[k], ring[(k + 1) % 8]), inside))
    return tris


def write_stl(path, name, tris):
    """Writes to a temporary name, then renames: a half-written mesh never replaces a whole one."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            n = unit(cross(sub(t[1], t[0]), sub(t[2], t[0])))
            f.write("  facet normal {:.6g} {:.6g} {:.6g}\n    outer loop\n".format(*n))
            for v in t:
                f.write("      vertex {:.9g} {:.9g} {:.9g}\n".format(*v))
            f.write("    endloop\n  endfacet\n")
        f.write(f"endsolid {name}\n")
    os.replace(tmp, path)


if __name__ == "__main__":
    here = os.path.dirname(os.path.abspath(__file__))
    os.makedirs(os.path.join(here, "meshes"), exist_ok=True)
    out = os.path.join(here, "meshes", "hourglass.stl")
    tris = hourglass()
    write_stl(out, "hourglass", tris)
    area = 7.0 / 2.25 * H_NECK ** 2  # the octagon's area is 7/2.25 h^2 (7 cm2 at h = 1.5 cm)
    print(f"{out}: {len(tris)} triangles; neck {2 * H_NECK * 1000:g} mm across its flats, "
          f"{area * 1e6:.2f} mm2 (a circle of {math.sqrt(4 * area / math.pi) * 1000:.2f} mm); "
          f"closed at z = +-{Z_END:g} m")
