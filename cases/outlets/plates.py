"""Flat plates of square cells as ASCII STL, for the outlet scenes' meshes (each scene's make_mesh.py):
a plate of nu x nv cells of side h from `origin` along u and v, without the cells `hole(i, j)` marks, and
planar quads for sloped walls."""
import os


def plate(origin, u, v, nu, nv, h, hole=lambda i, j: False):
    tris = []
    for i in range(nu):
        for j in range(nv):
            if hole(i, j):
                continue
            a = [origin[k] + i * h * u[k] + j * h * v[k] for k in range(3)]
            b = [a[k] + h * u[k] for k in range(3)]
            c = [b[k] + h * v[k] for k in range(3)]
            d = [a[k] + h * v[k] for k in range(3)]
            tris += [(a, b, c), (a, c, d)]
    return tris


def holes(ranges):
    """The `hole(i, j)` of plate() for square holes given as cell ranges (i0, i1, j0, j1): [i0, i1) x [j0, j1)."""
    return lambda i, j: any(i0 <= i < i1 and j0 <= j < j1 for i0, i1, j0, j1 in ranges)


def quad(a, b, c, d):
    """The planar quad a-b-c-d (corners in order round it) as two triangles."""
    return [(a, b, c), (a, c, d)]


def write_stl(path, tris):
    """Writes to a temporary name, then renames: a half-written mesh never replaces a whole one."""
    name = os.path.splitext(os.path.basename(path))[0]
    lines = ["solid " + name]
    for t in tris:
        lines += ["facet normal 0 0 0", "outer loop"] + ["vertex %.6f %.6f %.6f" % tuple(p) for p in t]
        lines += ["endloop", "endfacet"]
    lines.append("endsolid " + name)
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(lines) + "\n")
    os.replace(path + ".tmp", path)
