#!/usr/bin/python3
"""Granular pressure in a layer of grid cells against time, for several runs
(the paper's pressure figure: reference vs the fine level of an MLCG run with
and without the PI controller).

usage: scripts/plot_pressure.py OUT.png LABEL=GRID_DIR [LABEL=GRID_DIR ...]
       [--z 0.05] [--cells -0.02,0.02,-0.02,0.02] [--until T]
       [--window NAME:T0:T1 ...]

GRID_DIR is a run's grids/<name> folder (index.json + <name>_NNNNNN.h5).
The pressure is (s_xx + s_yy + s_zz) / 3 averaged over the cells whose centre
lies in the layer containing height z and inside the x/y window. Writes OUT.png
and OUT.csv (time, one column per run). With --window, prints and writes to
OUT_windows.csv each run's mean pressure over [T0, T1] and its deviation from
the first run's (the reference) over the same window. Needs Debian's python3-h5py and
python3-matplotlib (run with /usr/bin/python3).
"""
import argparse
import glob
import json
import os
import sys

import h5py
import numpy as np


def series(grid_dir, z, window):
    with open(os.path.join(grid_dir, "index.json")) as f:
        entries = json.load(f)["entries"]
    files = sorted(glob.glob(os.path.join(grid_dir, "*.h5")))
    times, values = [], []
    for e, path in zip(entries, files):
        with h5py.File(path, "r") as h:
            s = h["stress"][...]  # (nz, ny, nx, 6): xx xy xz yy yz zz
            origin = [h.attrs.get("origin_x"), h.attrs.get("origin_y"), h.attrs.get("origin_z")]
            cell = h.attrs.get("h")
        if None in origin or cell is None:
            sys.exit(f"{path}: no origin_x/y/z or h attributes; not an MLCG grid file")
        nz, ny, nx = s.shape[:3]
        k = int(np.floor((z - origin[2]) / cell))
        if not 0 <= k < nz:
            sys.exit(f"{grid_dir}: height {z} is outside the grid")
        xc = origin[0] + (np.arange(nx) + 0.5) * cell
        yc = origin[1] + (np.arange(ny) + 0.5) * cell
        ix = np.where((xc > window[0]) & (xc < window[1]))[0]
        iy = np.where((yc > window[2]) & (yc < window[3]))[0]
        p = (s[k][:, :, 0] + s[k][:, :, 3] + s[k][:, :, 5]) / 3.0
        times.append(e["time"])
        values.append(float(p[np.ix_(iy, ix)].mean()))
    return np.array(times), np.array(values)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("runs", nargs="+", help="LABEL=GRID_DIR")
    ap.add_argument("--z", type=float, default=0.05, help="a height inside the layer [m]")
    ap.add_argument("--cells", default="-0.02,0.02,-0.02,0.02", help="xmin,xmax,ymin,ymax of the cell centres [m]")
    ap.add_argument("--until", type=float, default=None, help="last time to plot [s]")
    ap.add_argument("--window", action="append", default=[], help="NAME:T0:T1, a time window to compare [s]")
    a = ap.parse_args()
    window = [float(v) for v in a.cells.split(",")]
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.2))
    cols = {}
    for spec in a.runs:
        label, _, d = spec.partition("=")
        t, p = series(d, a.z, window)
        if a.until is not None:
            keep = t <= a.until + 1e-12
            t, p = t[keep], p[keep]
        cols[label] = (t, p)
        ax.plot(t, p, label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("granular pressure [N/m²]")
    ax.set_title(f"pressure in the central cells of the layer at z = {a.z} m")
    ax.grid(True, alpha=0.3)
    ax.legend()
    fig.tight_layout()
    tmp = a.out + ".tmp.png"
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, a.out)
    base = os.path.splitext(a.out)[0]
    with open(base + ".csv.tmp", "w") as f:
        f.write("label,time_s,pressure_pa\n")
        for label, (t, p) in cols.items():
            for ti, pi in zip(t, p):
                f.write(f"{label},{ti:.6g},{pi:.6g}\n")
    os.replace(base + ".csv.tmp", base + ".csv")
    if a.window:
        write_windows(base + "_windows.csv", cols, a.window)


def write_windows(path, cols, windows):
    """Mean pressure of each run per window, and its deviation from the first run's."""
    labels = list(cols)
    rows = ["window,t0_s,t1_s,label,mean_pa,deviation_from_" + labels[0].replace(",", " ")]
    for spec in windows:
        name, t0, t1 = spec.split(":")
        t0, t1 = float(t0), float(t1)
        means = {}
        for label, (t, p) in cols.items():
            keep = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
            means[label] = float(p[keep].mean()) if keep.any() else float("nan")
        ref = means[labels[0]]
        for label in labels:
            dev = (means[label] - ref) / ref if ref else float("nan")
            rows.append(f"{name},{t0:g},{t1:g},{label},{means[label]:.4g},{dev:+.4f}")
            print(f"{name:>10} [{t0:g}, {t1:g}] s  {label:>24}: {means[label]:8.1f} N/m2  {100 * dev:+6.1f} %")
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(rows) + "\n")
    os.replace(path + ".tmp", path)


if __name__ == "__main__":
    main()
