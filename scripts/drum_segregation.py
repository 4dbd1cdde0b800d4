#!/usr/bin/python3
"""Radial segregation of a bidisperse fill in a rotating drum, from a run's particle snapshots.

In the rolling regime the small beads sift through the flowing layer and gather in the bed's core, the large
ones at its rim. The index is

    S = (mean distance of the large beads from the bed's centroid - that of the small ones) / that of all

in the drum's section (x, z), the beads split at the geometric mean of the smallest and largest radius (so a
coarse-grained run, every radius times alpha, splits the same way). S > 0: the small beads lie nearer the
core. A well-mixed bed reads a small positive S of its own (a large bead's centre cannot come as close to
the drum's wall); what segregation adds shows as S's rise over time.

  scripts/drum_segregation.py RUN [--from T] [--csv FILE] [--hierarchy]

RUN is a run folder (its particles/) or a hierarchy's level folder (levels/NAME); with --hierarchy, a two-level
MLCG run read as one bed: the fine level's beads inside its regions, the coarse level's parcels outside them,
each parcel counting as the alpha^3 beads it stands for. Prints S for every snapshot
and the mean from T on (default 2 s) with a 95 % t interval.
"""
import argparse
import glob
import json
import math
import os
import sys
import tomllib

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from drum_angle import snapshots, t95  # noqa: E402  (the same snapshot index and t table)


def read(path):
    with h5py.File(path, "r") as f:
        return np.asarray(f["position"]), np.asarray(f["radius"])


def segregation(x, r, alpha):
    """S of beads at x with radii r, each a parcel of alpha^3 beads of radius r / alpha (alpha = 1: beads)."""
    r1 = r / alpha
    if len(r) == 0 or r1.min() == r1.max():
        return None
    split = math.sqrt(r1.min() * r1.max())
    w = r ** 3  # mass
    c = np.array([np.sum(w * x[:, 0]), np.sum(w * x[:, 2])]) / np.sum(w)
    d = np.hypot(x[:, 0] - c[0], x[:, 2] - c[1])
    n = alpha ** 3  # beads per parcel: the means are over beads
    large, small = r1 > split, r1 <= split

    def mean(m):
        return np.sum(n[m] * d[m]) / np.sum(n[m])

    return (mean(large) - mean(small)) / mean(np.ones(len(r), bool)), int(small.sum()), int(large.sum())


def index(path):
    x, r = read(path)
    return segregation(x, r, np.ones(len(r)))


def hierarchy(run):
    """A two-level run (RUN/levels/<name>): its snapshots as one bed, the fine level's beads inside its regions
    and the coarse level's parcels outside them, as (time, x, r, alpha per particle)."""
    levels = sorted(d for d in glob.glob(os.path.join(run, "levels", "*")) if os.path.isdir(d))
    alpha = {d: json.load(open(os.path.join(d, "summary.json")))["levels"][0]["alpha"] for d in levels}
    if len(levels) != 2:
        sys.exit("drum_segregation: --hierarchy reads a run of two levels, %s has %d" % (run, len(levels)))
    coarse, fine = sorted(levels, key=lambda d: -alpha[d])
    with open(os.path.join(fine, "case.toml"), "rb") as f:
        regions = tomllib.load(f).get("coupling", {}).get("regions", [])
    fine_at = dict(snapshots(fine))
    for t, path in snapshots(coarse):
        near = [u for u in fine_at if abs(u - t) < 1e-6]
        if not near:
            continue
        xc, rc = read(path)
        xf, rf = read(fine_at[near[0]])
        outside = np.ones(len(rc), bool)
        for reg in regions:
            lo, hi = np.array(reg["min"]), np.array(reg["max"])
            outside &= ~np.all((xc >= lo) & (xc <= hi), axis=1)
        x = np.vstack([xf, xc[outside]])
        r = np.concatenate([rf, rc[outside]])
        a = np.concatenate([np.full(len(rf), alpha[fine]), np.full(outside.sum(), alpha[coarse])])
        yield t, x, r, a


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run")
    p.add_argument("--from", dest="t0", type=float, default=2.0, help="first snapshot of the mean [s] (default 2.0)")
    p.add_argument("--csv", help="also write time,S to this file")
    p.add_argument("--hierarchy", action="store_true",
                   help="RUN is a two-level MLCG run: one bed of the fine level's beads inside its regions and the "
                        "coarse level's parcels outside them (a parcel counts as alpha^3 beads)")
    a = p.parse_args()
    rows = []
    if a.hierarchy:
        beds = ((t, segregation(x, r, al)) for t, x, r, al in hierarchy(a.run))
    else:
        beds = ((t, index(path)) for t, path in snapshots(a.run))
    for t, s in beds:
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
