#!/usr/bin/python3
"""Radial segregation of a bidisperse fill in a rotating drum, from a run's particle snapshots.

In the rolling regime the small beads sift through the flowing layer and gather in the bed's core, the large
ones at its rim. The index is

    S = (mean distance of the large beads from the bed's centroid - that of the small ones) / that of all

in the drum's section (x, z), the beads split at the geometric mean of the smallest and largest radius (so a
coarse-grained run, every radius times alpha, splits the same way). S > 0: the small beads lie nearer the
core. A well-mixed bed reads a small positive S of its own (a large bead's centre cannot come as close to
the drum's wall); what segregation adds shows as S's rise over time.

  scripts/drum_segregation.py RUN [--from T] [--csv FILE]

RUN is a run folder (its particles/) or a hierarchy's level folder (levels/NAME). Prints S for every snapshot
and the mean from T on (default 2 s) with a 95 % t interval.
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from drum_angle import snapshots, t95  # noqa: E402  (the same snapshot index and t table)


def index(path):
    with h5py.File(path, "r") as f:
        x = np.asarray(f["position"])
        r = np.asarray(f["radius"])
    if len(r) == 0 or r.min() == r.max():
        return None
    split = math.sqrt(r.min() * r.max())
    w = r ** 3
    c = np.array([np.sum(w * x[:, 0]), np.sum(w * x[:, 2])]) / np.sum(w)
    d = np.hypot(x[:, 0] - c[0], x[:, 2] - c[1])
    large, small = r > split, r <= split
    return (d[large].mean() - d[small].mean()) / d.mean(), int(small.sum()), int(large.sum())


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run")
    p.add_argument("--from", dest="t0", type=float, default=2.0, help="first snapshot of the mean [s] (default 2.0)")
    p.add_argument("--csv", help="also write time,S to this file")
    a = p.parse_args()
    rows = []
    for t, path in snapshots(a.run):
        s = index(path)
        if s is None:
            continue
        rows.append((t, s[0]))
        print("t = %.3f s:  S = %+.4f (%d small, %d large)" % (t, s[0], s[1], s[2]))
    if a.csv:
        with open(a.csv + ".tmp", "w") as f:
            f.write("time_s,segregation_index\n")
            for t, s in rows:
                f.write("%.6g,%.6g\n" % (t, s))
        os.replace(a.csv + ".tmp", a.csv)
    late = np.array([s for t, s in rows if t >= a.t0 - 1e-9])
    if len(late) < 2:
        sys.exit("drum_segregation: fewer than 2 snapshots from t = %g s on in %s" % (a.t0, a.run))
    half = t95(len(late) - 1) * late.std(ddof=1) / math.sqrt(len(late))
    print("segregation index from %g s: %+.4f +- %.4f (95 %% t interval of %d snapshots; scatter %.4f)"
          % (a.t0, late.mean(), half, len(late), late.std(ddof=1)))


if __name__ == "__main__":
    main()
