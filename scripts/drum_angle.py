#!/usr/bin/python3
"""Dynamic angle of repose of a rotating drum, from a run's particle snapshots.

In the rolling regime the bed's free surface is a flat chord of the drum's circular section. The centroid of
a circular segment lies on the perpendicular from the circle's centre to its chord, so the chord's angle to
the horizontal is the angle between the bed's centroid direction (seen from the drum's axis) and the
downward vertical: no surface has to be found, and single particles bouncing above the bed barely move it.

  scripts/drum_angle.py RUN [--from T] [--center X Z] [--axis y] [--gravity GX GZ] [--liggghts [--dt DT]]

RUN is a run folder (its particles/), a hierarchy's level folder (levels/NAME), or with --liggghts the folder
of a LIGGGHTS run's `dump custom` files (dump*.liggghts: id type radius x y z ..., times = step x DT). Prints the angle of every
snapshot from T on and their mean with a 95 % t interval (snapshots 0.1 s apart are nearly independent
samples of the surface's fluctuation; the interval says how well the mean is pinned, not the scatter).
"""
import argparse
import glob
import json
import math
import os
import sys

import h5py
import numpy as np

T95 = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 9: 2.26, 10: 2.23, 15: 2.13,
       20: 2.09, 30: 2.04}


def t95(dof):
    keys = sorted(k for k in T95 if k <= dof)
    return T95[keys[-1]] if keys else T95[1]


def snapshots(run):
    folder = os.path.join(run, "particles")
    with open(os.path.join(folder, "index.json")) as f:
        index = json.load(f)
    for e in index["entries"]:
        yield e["time"], os.path.join(folder, "%s_%06d.h5" % (index["base"], e["index"]))


def liggghts_snapshots(folder, dt):
    for path in glob.glob(os.path.join(folder, "dump*.liggghts")):
        with open(path) as f:
            f.readline()
            step = int(f.readline())
        yield step * dt, path


def read_dump(path, velocity=False):
    with open(path) as f:
        lines = f.read().splitlines()
    head = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[head].split()[2:]
    data = np.array([l.split() for l in lines[head + 1:] if l.strip()], dtype=float).reshape(-1, len(cols))
    x, r = data[:, [cols.index("x"), cols.index("y"), cols.index("z")]], data[:, cols.index("radius")]
    if not velocity:
        return x, r
    if "vx" not in cols:
        sys.exit("%s: no vx vy vz columns (dump custom ... vx vy vz)" % path)
    return x, r, data[:, [cols.index("vx"), cols.index("vy"), cols.index("vz")]]


def read_particles(path):
    """Positions, radii and velocities of one snapshot: ours (.h5) or a LIGGGHTS dump (.liggghts)."""
    if path.endswith(".liggghts"):
        return read_dump(path, velocity=True)
    with h5py.File(path, "r") as f:
        return np.asarray(f["position"]), np.asarray(f["radius"]), np.asarray(f["velocity"])


def angle(path, center, axes, gravity=(0.0, -1.0)):
    if path.endswith(".liggghts"):
        x, r = read_dump(path)
    else:
        with h5py.File(path, "r") as f:
            x = np.asarray(f["position"])
            r = np.asarray(f["radius"])
    if len(r) == 0:
        return None
    w = r ** 3  # mass weights, one material
    a, b = axes  # horizontal and vertical in-plane coordinates
    cx = np.sum(w * (x[:, a] - center[0])) / np.sum(w)
    cz = np.sum(w * (x[:, b] - center[1])) / np.sum(w)
    gx, gz = gravity  # the angle between the centroid's direction and gravity's
    return math.degrees(math.atan2(abs(cx * gz - cz * gx), cx * gx + cz * gz)), len(r)


def drum_arguments(doc):
    """The arguments the drum's scripts share: the run, the first time, the axis and LIGGGHTS's dumps."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("run")
    p.add_argument("--from", dest="t0", type=float, default=2.0, help="first snapshot time [s] (default 2.0)")
    p.add_argument("--center", type=float, nargs=2, default=[0.0, 0.0], metavar=("X", "Z"),
                   help="the drum axis's position in the section [m] (default 0 0)")
    p.add_argument("--axis", choices=["x", "y"], default="y", help="the drum's axis (default y)")
    p.add_argument("--liggghts", action="store_true", help="RUN holds a LIGGGHTS run's dump*.liggghts files")
    p.add_argument("--dt", type=float, default=5e-6, help="the LIGGGHTS run's time step [s] (default 5e-6)")
    p.add_argument("--gravity", type=float, nargs=2, default=[0.0, -1.0], metavar=("GX", "GZ"),
                   help="gravity's direction in the section (default 0 -1; a case with tilted gravity, its x and z)")
    return p


def run_snapshots(args):
    """(time, path) of the run's snapshots from args.t0 on, in time order; and the section's axes."""
    found = liggghts_snapshots(args.run, args.dt) if args.liggghts else snapshots(args.run)
    axes = (0, 2) if args.axis == "y" else (1, 2)
    return [(t, path) for t, path in sorted(found) if t >= args.t0 - 1e-9], axes


def main():
    args = drum_arguments(__doc__).parse_args()
    rows = []
    found, axes = run_snapshots(args)
    for t, path in found:
        got = angle(path, args.center, axes, args.gravity)
        if got is None:
            continue
        rows.append((t, got[0], got[1]))
        print("t = %.3f s: %6.2f deg (%d particles)" % (t, got[0], got[1]))
    if len(rows) < 2:
        sys.exit("drum_angle: fewer than two snapshots from t = %g s in %s" % (args.t0, args.run))
    a = np.array([r[1] for r in rows])
    half = t95(len(a) - 1) * a.std(ddof=1) / math.sqrt(len(a))
    print("dynamic angle of repose: %.2f +- %.2f deg (95 %% t interval of %d snapshots, t >= %g s; scatter %.2f deg)"
          % (a.mean(), half, len(a), args.t0, a.std(ddof=1)))


if __name__ == "__main__":
    main()
