#!/usr/bin/env python3
"""<m_dot> +- its 95 % confidence interval through the hourglass's neck from the LIGGGHTS run of
cases/hourglass/in.hourglass_liggghts, over the window of reference.toml's probe 'neck'.

    python3 cases/hourglass/liggghts_rate.py RUN/neck_count.txt [--window T0 T1] [--case reference.toml]

The file (written by the input's `fix print`, 100 Hz) holds per row the time, the particles present and the
number and mass of the particles below z = 0 (the neck's centre). The hourglass is closed, so the mass below
z = 0 grows by the net mass through the neck: a sample is the mass it gained between two rows / their time
apart (kg/s), as the probe of an mlcg run samples the mass crossing its disk. Samples whose interval lies in
the window are kept; the mean, the standard deviation of the samples and the 95 % interval by batch means
follow mlcg's probe (common/stats/series_stats.hpp: batches of b samples, b doubled while the lag-1
autocorrelation of the batch means is above 0.1 and at least 10 batches remain, t quantile with B - 1
degrees of freedom). Plain python3 (3.11+, for tomllib), no packages.

The functions below (reading a count file, a probe's window from a case, the rates and their batch-means
interval, the report) are shared with cases/outlets/liggghts_rate.py and cases/feeder/liggghts_rate.py,
which import this file.
"""
import argparse
import math
import os
import sys
import tomllib

HERE = os.path.dirname(os.path.abspath(__file__))
MIN_BATCHES = 10
LAG1_LIMIT = 0.1


def read_table(path):
    """The columns' names (the `fix print` title line, '# t[s] particles ...', units in [] dropped) and
    the rows as lists of floats."""
    names, rows = [], []
    with open(path) as f:
        for line in f:
            s = line.split()
            if not s:
                continue
            if s[0].startswith("#"):
                if not names:
                    names = [w.split("[")[0] for w in " ".join(s)[1:].split()]
                continue
            rows.append([float(v) for v in s])
    return names, rows


def case_entries(case, key):
    """The case's array of tables `key` ('probes', 'events'), from the variant's `base` chain when the file
    has none (a variant's array replaces its base's whole)."""
    seen = set()
    while True:
        path = os.path.abspath(case)
        if path in seen:
            sys.exit(f"{case}: its base chain comes back to it")
        seen.add(path)
        with open(path, "rb") as f:
            c = tomllib.load(f)
        if key in c or "base" not in c:
            return c.get(key, [])
        case = os.path.join(os.path.dirname(path), c["base"])


def probe_window(case, name="neck"):
    """The window [s] of the case's probe `name`; a window relative to an event with `at` is moved by it."""
    for p in case_entries(case, "probes"):
        if p.get("name") == name:
            t0, t1 = (float(x) for x in p.get("window", [0.0, math.inf]))
            ev = p.get("window_relative_to")
            if ev is not None:
                at = next((e.get("at") for e in case_entries(case, "events") if e.get("name") == ev), None)
                if at is None:
                    sys.exit(f"{case}: probe '{name}' has a window relative to event '{ev}', "
                             "which has no fixed time 'at'; give --window")
                t0, t1 = t0 + float(at), t1 + float(at)
            return t0, t1
    sys.exit(f"{case}: no probe '{name}'; give --window")


def lag1(x):
    if len(x) < 2:
        return 0.0
    m = sum(x) / len(x)
    den = sum((v - m) ** 2 for v in x)
    num = sum((x[i] - m) * (x[i + 1] - m) for i in range(len(x) - 1))
    return num / den if den > 0 else 0.0


def batch_means(x, b):
    nb = len(x) // b
    skip = len(x) - nb * b
    return [sum(x[skip + i * b: skip + (i + 1) * b]) / b for i in range(nb)]


def t_quantile_975(dof):
    """t with P(T <= t) = 0.975 (A&S 26.7.3-4 inverted by bisection, as series_stats.cpp)."""
    def two_sided(theta):
        s, c = math.sin(theta), math.cos(theta)
        c2 = c * c
        if dof % 2 == 1:
            total = 0.0
            if dof > 1:
                term = c
                total = term
                for j in range(3, dof - 1, 2):
                    term *= c2 * (j - 1) / j
                    total += term
            return 2.0 / math.pi * (theta + s * total)
        term, total = 1.0, 1.0
        for j in range(2, dof - 1, 2):
            term *= c2 * (j - 1) / j
            total += term
        return s * total
    lo, hi = 0.0, 0.5 * math.pi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if two_sided(mid) < 0.95:
            lo = mid
        else:
            hi = mid
    return math.sqrt(dof) * math.tan(0.5 * (lo + hi))


def window_rates(times, masses, t0, t1):
    """The samples: the mass gained between two rows / their time apart, for the rows' intervals inside
    [t0, t1] (kg/s)."""
    return [(mb - ma) / (tb - ta) for ta, tb, ma, mb in zip(times, times[1:], masses, masses[1:])
            if ta >= t0 - 1e-9 and tb <= t1 + 1e-9 and tb > ta]


def batch_means_ci(rates):
    """(mean, sigma, half-width of the 95 % interval, batches, samples per batch, lag-1 of the batch
    means) of the samples, as mlcg's probe (series_stats.hpp)."""
    n = len(rates)
    mean = sum(rates) / n
    sigma = math.sqrt(max(0.0, sum(r * r for r in rates) / n - mean * mean))
    b, m = 1, list(rates)
    r1 = lag1(m)
    while r1 > LAG1_LIMIT and n // (2 * b) >= MIN_BATCHES:
        b *= 2
        m = batch_means(rates, b)
        r1 = lag1(m)
    nb = len(m)
    mb = sum(m) / nb
    var_b = sum((v - mb) ** 2 for v in m) / (nb - 1)
    ci = t_quantile_975(nb - 1) * math.sqrt(var_b / nb)
    return mean, sigma, ci, nb, b, r1


def report(label, times, present, masses, t0, t1):
    """Prints <m_dot> +- its 95 % interval and sigma over [t0, t1] of the cumulative `masses` [kg] at
    `times` [s]; `present` = the particles in the box at each row (a drop inside the window is warned of:
    particles lost from the box are missing from the counted mass), or None where lost particles are counted."""
    if len(times) < 2:
        sys.exit(f"{label}: fewer than 2 rows")
    rates = window_rates(times, masses, t0, t1)
    last = times[-1]
    if len(rates) < 2:
        sys.exit(f"{label}: {len(rates)} sample(s) in the window [{t0:g}, {t1:g}] s (the file ends at {last:g} s)")
    mean, sigma, ci, nb, b, r1 = batch_means_ci(rates)
    note = "" if r1 <= LAG1_LIMIT else f" (lag-1 of the batch means {r1:.2f} > 0.1: the window is short for its correlation time; the interval is likely too narrow)"
    held = "" if present is None else f"; particles present {int(min(present))}..{int(max(present))}"
    print(f"{label}: window [{t0:g}, {t1:g}] s, {len(rates)} samples at {1.0 / (times[1] - times[0]):.0f} Hz "
          f"(file to {last:g} s{held})")
    print(f"<m_dot> = {mean:.6g} kg/s +- {ci:.2g} kg/s (95 % CI, batch means: {nb} batches of {b} samples){note}")
    print(f"sigma(m_dot) = {sigma:.3g} kg/s")
    inside = [] if present is None else [p for t, p in zip(times, present) if t0 - 1e-9 <= t <= t1 + 1e-9]
    if any(q < p for p, q in zip(inside, inside[1:])):
        print(f"warning: particles left the box during the window ({int(max(inside) - inside[-1])} fewer at its end "
              "than at most): the counted mass misses them")
    if t1 > last + 1e-9:
        print(f"warning: the window ends at {t1:g} s, after the file's last row ({last:g} s)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", help="neck_count.txt written by in.hourglass_liggghts")
    ap.add_argument("--window", nargs=2, type=float, metavar=("T0", "T1"),
                    help="time window [s]; default: the window of the case's probe 'neck'")
    ap.add_argument("--case", default=os.path.join(HERE, "reference.toml"),
                    help="the case whose probe 'neck' gives the window (default: reference.toml next to this script)")
    a = ap.parse_args()
    t0, t1 = a.window if a.window else probe_window(a.case)
    _, rows = read_table(a.file)
    # columns: t, particles present, particles below z = 0, mass below z = 0
    report(a.file, [r[0] for r in rows], [r[1] for r in rows], [r[3] for r in rows], t0, t1)


if __name__ == "__main__":
    main()
