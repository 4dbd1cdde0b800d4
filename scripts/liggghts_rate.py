#!/usr/bin/python3
"""Mass rate past a plane from a LIGGGHTS run's dump files, as an MLCG probe would report it.

  scripts/liggghts_rate.py DIR --axis x --beyond 0.095 --density 1000 --dt 5e-6 --open 0.25 --window 0.6 1.6

DIR holds `dump custom` files (dump*.liggghts with columns id ... radius x y z ...), written at a fixed interval.
A particle counts once, in the first dump that shows it past the plane (coordinate AXIS beyond BEYOND, or below
it with --below); a dump's interval must be short enough that no particle crosses the plane and leaves the box
between two dumps (the feeder's: 0.01 s, against about 0.1 s from the plane to the box's floor). The samples are
the mass counted per dump interval over that interval [kg/s] (0.01 s apart: the 100 Hz of a probe), and the
window is [OPEN + W0, OPEN + W1] s like a probe's `window_relative_to`. Prints the mean rate, its standard
deviation and the half-width of the mean's 95 % interval by batch means, the method of an MLCG summary
(docs/validation.md, Uncertainty): b doubles from 1 while the lag-1 autocorrelation of the batch means is above
0.1 and at least 10 batches remain; half-width t(0.975, B - 1) s_B / sqrt(B).
"""
import argparse
import glob
import math
import os
import sys


def t975(dof):
    """Student's t 0.975 quantile by bisection on the distribution's series (whole dof >= 1)."""
    def cdf(t):
        x = dof / (dof + t * t)
        # regularised incomplete beta I_x(dof/2, 1/2) by continued fraction (Numerical Recipes' betacf)
        a, b = dof / 2.0, 0.5
        lbeta = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
        front = math.exp(lbeta + a * math.log(x) + b * math.log(1.0 - x)) / a
        c, d = 1.0, 1.0 - (a + b) * x / (a + 1.0)
        d = 1.0 / d
        f = d
        for m in range(1, 300):
            for num in (m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
                        -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))):
                d = 1.0 + num * d
                d = 1.0 / d
                c = 1.0 + num / c
                f *= d * c
        return 1.0 - 0.5 * front * f
    lo, hi = 0.0, 100.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if cdf(mid) < 0.975 else (lo, mid)
    return 0.5 * (lo + hi)


def lag1(x):
    n = len(x)
    if n < 2:
        return 0.0
    m = sum(x) / n
    s2 = sum((v - m) ** 2 for v in x)
    if s2 == 0.0:
        return 0.0
    return sum((x[i] - m) * (x[i + 1] - m) for i in range(n - 1)) / s2


def batch_means_ci(x):
    n = len(x)
    mean = sum(x) / n
    b = 1
    while True:
        nb = n // b
        means = [sum(x[n - (k + 1) * b:n - k * b]) / b for k in range(nb)][::-1]
        if lag1(means) <= 0.1 or n // (2 * b) < 10:
            break
        b *= 2
    mb = sum(means) / nb
    sb = math.sqrt(sum((v - mb) ** 2 for v in means) / (nb - 1))
    return mean, t975(nb - 1) * sb / math.sqrt(nb), nb, b


def read_dump(path, axis):
    with open(path) as f:
        lines = f.read().splitlines()
    step = int(lines[1])
    head = next(i for i, l in enumerate(lines) if l.startswith("ITEM: ATOMS"))
    cols = lines[head].split()[2:]
    ci, cx, cr = cols.index("id"), cols.index(axis), cols.index("radius")
    rows = [l.split() for l in lines[head + 1:] if l.strip()]
    return step, [(int(r[ci]), float(r[cx]), float(r[cr])) for r in rows]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir")
    ap.add_argument("--axis", choices="xyz", default="z")
    ap.add_argument("--beyond", type=float, required=True, help="the plane's coordinate along AXIS [m]")
    ap.add_argument("--below", action="store_true", help="count particles below the plane instead of beyond it")
    ap.add_argument("--density", type=float, required=True, help="particle density [kg/m3]")
    ap.add_argument("--dt", type=float, required=True, help="LIGGGHTS's time step [s]")
    ap.add_argument("--open", type=float, default=0.0, help="the time the window is relative to [s]")
    ap.add_argument("--window", type=float, nargs=2, required=True, metavar=("W0", "W1"))
    a = ap.parse_args()
    dumps = sorted((read_dump(p, a.axis) for p in glob.glob(os.path.join(a.dir, "dump*.liggghts"))),
                   key=lambda d: d[0])
    if len(dumps) < 2:
        sys.exit(f"liggghts_rate: fewer than two dump*.liggghts files in {a.dir}")
    seen = set()
    series = []  # (t_start, t_end, mass counted in (t_start, t_end])
    prev_t = dumps[0][0] * a.dt
    for step, rows in dumps:
        t = step * a.dt
        mass = 0.0
        for pid, coord, r in rows:
            past = coord < a.beyond if a.below else coord > a.beyond
            if past and pid not in seen:
                seen.add(pid)
                mass += a.density * 4.0 / 3.0 * math.pi * r ** 3
        if step != dumps[0][0]:
            series.append((prev_t, t, mass))
        prev_t = t
    w0, w1 = a.open + a.window[0], a.open + a.window[1]
    eps = 1e-9
    samples = [m / (t1 - t0) for t0, t1, m in series if t0 >= w0 - eps and t1 <= w1 + eps]
    if len(samples) < 2:
        sys.exit(f"liggghts_rate: fewer than two samples in the window [{w0:g}, {w1:g}] s")
    mean, ci, nb, b = batch_means_ci(samples)
    n = len(samples)
    sd = math.sqrt(sum((v - mean) ** 2 for v in samples) / (n - 1))
    print(f"{a.dir}: {len(seen)} particles counted past {a.axis} = {a.beyond:g} m; window [{w0:g}, {w1:g}] s, "
          f"{n} samples of {series[0][1] - series[0][0]:g} s")
    print(f"<m_dot> = {mean:.6g} +- {ci:.2g} kg/s (95 %, batch means, {nb} batches of {b}); sigma = {sd:.3g} kg/s")


if __name__ == "__main__":
    main()
