#!/usr/bin/env python3
"""<m_dot> +- its 95 % confidence interval through one outlet of an outlets scene from its LIGGGHTS run
(cases/outlets/*/in.*_liggghts), over the window of the case's probe of that name.

    python3 cases/outlets/liggghts_rate.py RUN/outlet_count.txt OUTLET --case SCENE/reference.toml [--window T0 T1]

OUTLET is a probe's name in the case ('a' or 'b' in two_outlets, 'hole' in side_outlet). The file (written
by the input's `fix print`, 100 Hz, the probes' rate) holds per row the time, the particles present and, per
outlet, the number and mass of the particles past its probe (columns n_OUTLET, m_OUTLET): no particle leaves
the LIGGGHTS box and none comes back, so that mass grows by the mass through the probe. A sample is the mass
it gained between two rows / their time apart (kg/s). The window is the probe's (`window`, moved by the
time `at` of the event named by `window_relative_to`: [0.2, 0.6] s after 'open' at 0.5 s is 0.7-1.1 s);
--window T0 T1 gives another. Mean, standard deviation and the 95 % interval by batch means are those of
cases/hourglass/liggghts_rate.py (one implementation, imported from it), which follow mlcg's probe. A drop
of the particles present inside the window (particles lost from the box, missing from the count) is
warned of. Plain python3 (3.11+, for tomllib), no packages.
"""
import argparse
import importlib.util
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location(
    "hourglass_liggghts_rate", os.path.join(HERE, "..", "hourglass", "liggghts_rate.py"))
shared = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(shared)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("file", help="outlet_count.txt written by the scene's in.*_liggghts")
    ap.add_argument("outlet", help="the probe's name: its mass column m_OUTLET and its window in the case")
    ap.add_argument("--case", help="the scene's case (reference.toml) whose probe OUTLET gives the window")
    ap.add_argument("--window", nargs=2, type=float, metavar=("T0", "T1"),
                    help="time window [s] instead of the probe's")
    a = ap.parse_args()
    if a.window:
        t0, t1 = a.window
    elif a.case:
        t0, t1 = shared.probe_window(a.case, a.outlet)
    else:
        sys.exit("give --case (the scene's reference.toml) or --window")
    names, rows = shared.read_table(a.file)
    col = "m_" + a.outlet
    if col not in names or "t" not in names or "particles" not in names:
        sys.exit(f"{a.file}: no column '{col}' (columns: {' '.join(names) or 'no title line'})")
    it, ip, im = names.index("t"), names.index("particles"), names.index(col)
    shared.report(f"{a.file} [{a.outlet}]", [r[it] for r in rows], [r[ip] for r in rows],
                  [r[im] for r in rows], t0, t1)


if __name__ == "__main__":
    main()
