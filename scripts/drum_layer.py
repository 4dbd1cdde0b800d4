#!/usr/bin/python3
"""Flowing layer of a rotating drum: its thickness and surface velocity, from a run's particle snapshots.

In the rolling regime the bed turns with the drum as a solid body under a thin layer that flows down its flat
free surface. Along the perpendicular from the drum's axis to the surface (the middle of the surface), the
downslope velocity u falls from the surface velocity at the top to zero at the layer's bottom and below it
follows the drum's rotation (u = -omega x depth from the axis). Per snapshot, in a strip of half-width W about
that perpendicular (the whole drum length), in bins half a mean diameter deep:

  surface    the plane where the bed's centres thin out to half their density in the bulk, plus one mean
             radius (the top beads' surfaces; the bulk: 3 to 8 mean diameters below the top);
  thickness  from the surface down to where u changes sign (linear between bin centres);
  u_s        the mass-weighted mean downslope velocity of the beads within one mean diameter of the surface;
  omega      the slope of u over depth from 2 mean diameters below the layer down: the drum's rate for a bed
             turning as a solid body, steeper where the bed under the layer creeps (slower than the drum).

The surface's orientation comes from the bed's centroid as in scripts/drum_angle.py, or from --angle where RUN
holds only part of the bed (the fine level of a hierarchy whose region is a slice through it).

  scripts/drum_layer.py RUN [--from T] [--center X Z] [--axis y] [--strip W] [--angle DEG] [--liggghts [--dt DT]]
                        [--csv FILE]

RUN is a run folder (its particles/), a hierarchy's level folder (levels/NAME), or with --liggghts the folder
of a LIGGGHTS run's `dump custom` files with radius, x y z and vx vy vz. Prints every snapshot from T on and the
means with a 95 % t interval.
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from drum_angle import drum_arguments, read_particles, run_snapshots, t95  # noqa: E402


def frame(p, w, angle=None, gravity=(0.0, -1.0)):
    """Unit normal n (out of the bed's surface) and downslope tangent t in the section, from the centroid, or
    with `angle` [deg] from the surface's angle (the centroid then gives only the side the bed lies on)."""
    c = (w[:, None] * p).sum(axis=0) / w.sum()
    if angle is not None:
        a = math.radians(angle)
        c = np.array([math.copysign(math.sin(a), c[0]), -math.cos(a)])
    n = -c / np.linalg.norm(c)
    t = np.array([n[1], -n[0]])
    if t @ np.asarray(gravity) < 0.0:  # downslope: along gravity
        t = -t
    return n, t


def crossing(z, f, level):
    """Scanning from the last entry down: the first z where f falls through `level` (linear), or None."""
    for k in range(len(z) - 1, 0, -1):
        if f[k] < level <= f[k - 1]:
            return z[k] + (level - f[k]) * (z[k - 1] - z[k]) / (f[k - 1] - f[k])
    return None


def layer(path, center, axes, strip_diameters, angle=None, gravity=(0.0, -1.0)):
    x, r, v = read_particles(path)
    if len(r) < 50:
        return None
    a, b = axes
    p = np.column_stack([x[:, a] - center[0], x[:, b] - center[1]])
    u2 = np.column_stack([v[:, a], v[:, b]])
    w = r ** 3  # mass weights, one material
    n, t = frame(p, w, angle, gravity)
    zeta, xi, u = p @ n, p @ t, u2 @ t
    rbar = r.mean()
    keep = np.abs(xi) < strip_diameters * 2.0 * rbar
    zeta, u, w = zeta[keep], u[keep], w[keep]
    h = rbar  # bins half a mean diameter deep
    top = np.percentile(zeta, 99.0)
    edges = np.arange(zeta.min(), top + 3.0 * h, h)
    mid = 0.5 * (edges[1:] + edges[:-1])
    k = np.digitize(zeta, edges) - 1
    ok = (k >= 0) & (k < len(mid))
    vol = np.bincount(k[ok], weights=w[ok], minlength=len(mid))
    mom = np.bincount(k[ok], weights=(w * u)[ok], minlength=len(mid))
    cnt = np.bincount(k[ok], minlength=len(mid))
    bulk = (mid > top - 16.0 * rbar) & (mid < top - 6.0 * rbar)
    if not bulk.any():
        return None
    z_centres = crossing(mid, vol, 0.5 * vol[bulk].mean())
    if z_centres is None:
        return None
    surface = z_centres + rbar
    filled = cnt >= 3
    zf, uf = mid[filled], mom[filled] / vol[filled]
    below = zf < surface
    zf, uf = zf[below], uf[below]
    bottom = None
    for j in range(len(zf) - 1, 0, -1):  # from the top down: the first sign change from + to -
        if uf[j] > 0.0 >= uf[j - 1]:
            bottom = zf[j] + uf[j] * (zf[j - 1] - zf[j]) / (uf[j] - uf[j - 1])
            break
    if bottom is None:
        return None
    top_layer = zeta > surface - 2.0 * rbar
    u_s = np.sum(w[top_layer] * u[top_layer]) / np.sum(w[top_layer])
    fit = zf < bottom - 4.0 * rbar
    omega = abs(np.polyfit(zf[fit], uf[fit], 1)[0]) if fit.sum() >= 3 else float("nan")
    return surface - bottom, u_s, omega, 2.0 * rbar, int(keep.sum())


def main():
    p = drum_arguments(__doc__)
    p.add_argument("--strip", type=float, default=3.0,
                   help="the strip's half-width about the surface's middle, in mean diameters (default 3)")
    p.add_argument("--angle", type=float,
                   help="the surface's angle [deg] (drum_angle.py's) where RUN holds part of the bed only (a fine "
                        "level's slice); default: from RUN's own centroid")
    p.add_argument("--csv", help="also write time, thickness, surface velocity and bulk rate to this file")
    args = p.parse_args()
    found, axes = run_snapshots(args)
    rows = []
    for t, path in found:
        got = layer(path, args.center, axes, args.strip, args.angle, args.gravity)
        if got is None:
            print("t = %.3f s: no layer found (too few beads, or no bed turning under a flowing top)" % t)
            continue
        rows.append((t,) + got)
        print("t = %.3f s: layer %.2f mm (%.2f diameters), surface velocity %.4f m/s, bulk %.3f rad/s (%d beads in "
              "the strip)" % (t, 1e3 * got[0], got[0] / got[3], got[1], got[2], got[4]))
    if len(rows) < 2:
        sys.exit("drum_layer: fewer than two snapshots with a layer from t = %g s in %s" % (args.t0, args.run))
    if args.csv:
        with open(args.csv + ".tmp", "w") as f:
            f.write("time_s,thickness_m,surface_velocity_m_s,bulk_rate_rad_s\n")
            for row in rows:
                f.write("%.6g,%.6g,%.6g,%.6g\n" % row[:4])
        os.replace(args.csv + ".tmp", args.csv)
    m = len(rows)
    d = np.array([row[1] for row in rows])
    us = np.array([row[2] for row in rows])
    om = np.array([row[3] for row in rows])
    dia = rows[0][4]

    def ci(a):
        return t95(m - 1) * a.std(ddof=1) / math.sqrt(m)

    print("flowing layer: %.2f +- %.2f mm (%.2f diameters of %.2f mm); surface velocity %.4f +- %.4f m/s; bulk "
          "%.3f +- %.3f rad/s (95 %% t intervals of %d snapshots, t >= %g s)"
          % (1e3 * d.mean(), 1e3 * ci(d), d.mean() / dia, 1e3 * dia, us.mean(), ci(us), np.nanmean(om), ci(om), m,
             args.t0))


if __name__ == "__main__":
    main()
