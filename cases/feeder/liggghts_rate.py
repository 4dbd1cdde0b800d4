#!/usr/bin/env python3
"""<m_dot> +- its 95 % confidence interval off the feeder's belt from the LIGGGHTS run of
cases/feeder/in.feeder_liggghts, over the window of reference.toml's probe 'belt_end'.

    python3 cases/feeder/liggghts_rate.py RUN [--open 0.25] [--window W0 W1]

RUN holds the run's dump files (dump*.liggghts, every 0.01 s, only the particles past x = 0.095 m: the
probe's plane, 5 mm past the belt's end). A particle counts once, in the first dump that shows it past the
plane; it falls to the box's floor (and is dropped there) in about 0.1 s, so no particle crosses the plane
and leaves the box between two dumps. The cumulative counted mass at the dumps' times gives the samples
(the mass gained between two dumps / 0.01 s, the probes' 100 Hz), and the window is the probe's, after the
lid went at OPEN (the input's `open`, 0.25 s). Mean, standard deviation and the 95 % interval by batch
means are those of cases/hourglass/liggghts_rate.py (one implementation, imported from it), which follow
mlcg's probe. Plain python3 (3.11+), no packages.
"""
import argparse
import glob
import importlib.util
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location(
    "hourglass_liggghts_rate", os.path.join(HERE, "..", "hourglass", "liggghts_rate.py"))
shared = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(shared)

PLANE_X = 0.095     # the probe's plane [m]
DENSITY = 1000.0    # the particles' [kg/m3]
DT = 5e-6           # the input's time step [s]


def read_dump(path):
    """(step, [(id, x, radius)]) of a `dump custom` file with columns id ... radius x ..."""
    with open(path) as f:
        lines = f.read().splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    cols = lines[head].split()[2:]
    ci, cx, cr = cols.index("id"), cols.index("x"), cols.index("radius")
    rows = [line.split() for line in lines[head + 1:] if line.strip()]
    return int(lines[1]), [(int(r[ci]), float(r[cx]), float(r[cr])) for r in rows]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run", help="the LIGGGHTS run's folder (its dump*.liggghts)")
    ap.add_argument("--open", type=float, default=0.25, help="when the lid went [s] (the input's `open`)")
    ap.add_argument("--window", nargs=2, type=float, metavar=("W0", "W1"),
                    help="the window after OPEN [s]; default: the window of reference.toml's probe 'belt_end'")
    a = ap.parse_args()
    if a.window:
        w0, w1 = a.window
    else:  # relative to the event 'open', which fires on a condition in reference.toml: the window as written
        probe = next(p for p in shared.case_entries(os.path.join(HERE, "reference.toml"), "probes")
                     if p.get("name") == "belt_end")
        w0, w1 = (float(x) for x in probe["window"])
    dumps = sorted((read_dump(p) for p in glob.glob(os.path.join(a.run, "dump*.liggghts"))), key=lambda d: d[0])
    if len(dumps) < 2:
        sys.exit(f"{a.run}: fewer than two dump*.liggghts files")
    seen, total, times, masses = set(), 0.0, [], []
    for step, rows in dumps:
        for pid, x, r in rows:
            if x > PLANE_X and pid not in seen:
                seen.add(pid)
                total += DENSITY * 4.0 / 3.0 * math.pi * r ** 3
        times.append(step * DT)
        masses.append(total)
    shared.report(f"{a.run} [belt_end, {len(seen)} particles past x = {PLANE_X:g} m]", times, None, masses,
                  a.open + w0, a.open + w1)


if __name__ == "__main__":
    main()
