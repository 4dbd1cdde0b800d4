#!/usr/bin/python3
"""Plots of an `mlcg study` folder (called by `mlcg study`; can be rerun by hand).

usage: scripts/plot_study.py STUDY_DIR

Reads STUDY_DIR/study.json and writes into STUDY_DIR:
  error_vs_time.png  |error of <m_dot>| against wall time, one labelled point per
                     variant with the error's 95 % interval as an error bar
                     (none for a run that recorded no interval), the Pareto
                     front (no other variant is both faster and more accurate)
                     marked; a sweep's points joined in order
  discharge.png      mass flow against time of every variant (its probe CSV; a
                     hierarchy's finest level)
  pressure.png       granular pressure in the central cells of the transition
                     layer (top cell layer of the fine region) against time:
                     reference and the MLCG variants (only when the study has a
                     fine region and the runs wrote a grid covering the layer;
                     needs h5py)
Needs Debian's python3-matplotlib (run with /usr/bin/python3). Exit code 3 when
matplotlib is missing.
"""
import csv
import json
import math
import os
import sys


def save(fig, path):
    tmp = path + ".tmp.png"
    fig.savefig(tmp, dpi=120)
    os.replace(tmp, path)


def pareto(points):
    """Indices of the points no other point beats in both wall time and |error|."""
    front = []
    for i, (t, e) in enumerate(points):
        if not any((t2 <= t and e2 <= e) and (t2 < t or e2 < e) for j, (t2, e2) in enumerate(points) if j != i):
            front.append(i)
    return sorted(front, key=lambda i: points[i][0])


def error_vs_time(plt, study, out):
    vs = study["variants"]
    pts = [(v["wall_s"], abs(v["error_pct"])) for v in vs]
    front = pareto(pts)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    sweeps = {}
    for v, (t, e) in zip(vs, pts):
        if v["sweep"]:
            sweeps.setdefault(v["sweep"], []).append((t, e))
    for name, p in sweeps.items():
        ax.plot([q[0] for q in p], [q[1] for q in p], "-", color="0.7", zorder=1, label=f"sweep '{name}'")
    # The error's 95 % interval; runs written before intervals were recorded have none (null).
    ci = [v.get("error_ci_pct") for v in vs]
    ax.errorbar([p[0] for p in pts], [p[1] for p in pts], yerr=[c if c is not None else 0.0 for c in ci], fmt="o",
                ms=6, color="C0", ecolor="C0", elinewidth=1.2, capsize=4, zorder=2,
                label="variant (bar: 95 % interval of the error)")
    ax.plot([pts[i][0] for i in front], [pts[i][1] for i in front], "o--", color="C3", mfc="none", ms=12,
            zorder=3, label="Pareto front")
    # Labels of points that lie close together are stacked, not printed over one another.
    placed = []
    for i in sorted(range(len(vs)), key=lambda i: pts[i]):
        v, (t, e) = vs[i], pts[i]
        text = v["label"] + (" (reference)" if v["name"] == study["reference"] else "")
        near = sum(1 for (t2, e2) in placed if abs(math.log(t / t2)) < 0.35 and abs(e - e2) < 1.5)
        placed.append((t, e))
        ax.annotate(text, (t, e), textcoords="offset points", xytext=(6, 6 + 11 * near), fontsize=8)
    ax.set_xscale("log")
    from matplotlib.ticker import FuncFormatter
    plain = FuncFormatter(lambda x, _: f"{x:g}")  # 20, not 2×10¹
    # Minor ticks labelled only at 2 and 5 × 10^k: all eight crowd into one another over a decade.
    sparse = FuncFormatter(lambda x, _: f"{x:g}" if round(x / 10 ** math.floor(math.log10(x))) in (2, 5) else "")
    ax.xaxis.set_major_formatter(plain)
    ax.xaxis.set_minor_formatter(sparse)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("|error of ⟨ṁ⟩| against the reference [%]")
    ax.set_title(study.get("title") or "error against run time")
    ax.set_ylim(bottom=0.0, top=max(1.0, 1.15 * max(p[1] + (c or 0.0) for p, c in zip(pts, ci))))
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, out)


def discharge(plt, study, out):
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for v in study["variants"]:
        t, m = [], []
        try:
            with open(v["probe_csv"]) as f:
                for row in csv.DictReader(f):
                    t.append(float(row["t"]))
                    m.append(float(row["mass_flow_kg_per_s"]))
        except OSError as e:
            print(f"plot_study.py: {v['name']}: {e}; left out of {out}", file=sys.stderr)
            continue
        style = "-" if v["name"] == study["reference"] else ("--" if v["sweep"] else "-")
        lw = 2.0 if v["name"] == study["reference"] else 1.2
        ci = v.get("ci95_kg_per_s")
        pm = f" ± {ci:.4f}" if ci is not None else ""
        ax.plot(t, m, style, lw=lw, label=f"{v['label']}: ⟨ṁ⟩ = {v['mdot_kg_per_s']:.4f}{pm} kg/s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"mass flow through probe '{study['variants'][0]['probe']}' [kg/s]")
    ax.set_title("discharge")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, out)


def pressure(plt, study, out):
    p = study.get("pressure")
    if not p or len(p["runs"]) < 2:
        return
    try:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from plot_pressure import series  # the layer average of plot_pressure.py
    except ImportError as e:
        print(f"plot_study.py: no pressure.png ({e}; needs python3-h5py)", file=sys.stderr)
        return
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for r in p["runs"]:
        try:
            t, v = series(r["grid_dir"], p["z"], p["window"])
        except SystemExit as e:  # the layer lies outside that run's grid
            print(f"plot_study.py: {r['label']}: left out of {out}: {e}", file=sys.stderr)
            continue
        if len(v) and not any(x != 0.0 for x in v):  # a hierarchy whose finest region ends below the layer
            print(f"plot_study.py: {r['label']}: left out of {out}: no particles of its level in the layer "
                  f"(its region ends below it)", file=sys.stderr)
            continue
        ax.plot(t, v, label=r["label"])
    lo, hi = p["layer"]
    ax.set_xlabel("time [s]")
    ax.set_ylabel("granular pressure [N/m²]")
    ax.set_title(f"transition layer z = {lo:g}–{hi:g} m, central cells (grid '{p['grid']}')")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    save(fig, out)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    folder = sys.argv[1]
    with open(os.path.join(folder, "study.json")) as f:
        study = json.load(f)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"plot_study.py: {e}; install python3-matplotlib", file=sys.stderr)
        sys.exit(3)
    error_vs_time(plt, study, os.path.join(folder, "error_vs_time.png"))
    discharge(plt, study, os.path.join(folder, "discharge.png"))
    pressure(plt, study, os.path.join(folder, "pressure.png"))
    print(f"plots: {folder}/error_vs_time.png, discharge.png"
          + (", pressure.png" if os.path.exists(os.path.join(folder, "pressure.png")) else ""))


if __name__ == "__main__":
    main()
