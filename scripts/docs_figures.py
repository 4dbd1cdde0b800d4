#!/usr/bin/python3
"""The pictures of README.md and docs/, each from data kept in the repository (no run is started).

usage: scripts/docs_figures.py accuracy|speed|hopper|paraview|all

  accuracy  docs/img/accuracy_silo_paper.png: error of <m_dot> against CPU time relative to the
            reference, with the error's 95 % interval, for the runs of cases/silo_paper/results/study.csv,
            beside the paper's Table 2 (docs/data/paper_table2.csv: its error and speedup; the paper
            gives sigma, not an interval, so its points have no bar)
  speed     docs/img/speed_vs_liggghts.png: mlcg_bench per-core rates against LIGGGHTS on the bed and
            discharge scenes at 1 and 2 ranks (docs/data/bench_speed.csv), and the size sweep
            (docs/data/bench_sweep.csv)
  hopper    docs/img/hopper_steep_cone.png: cases/hoppers/results/steep_cone.md, <m_dot> +- 95 % CI at the
            outlet probe for the reference, coarse grain and MLCG, with the six hoppers' errors beside it
            (cases/hoppers/results/*.md)
  paraview  docs/img/silo_small_paraview.png: a copy of cases/silo_small/results/silo_small_mlcg_paraview.png
            (made by scripts/render_paraview.py, see docs/running.md)

Needs Debian's python3-matplotlib (scripts/setup.sh installs it). Every PNG must stay under 300 KB
(tests/docs/test_doc_commands.py checks it).
"""
import csv
import re
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
IMG = ROOT / "docs" / "img"
DATA = ROOT / "docs" / "data"


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save(fig, name):
    IMG.mkdir(parents=True, exist_ok=True)
    out = IMG / name
    fig.savefig(out, dpi=100)
    print(f"{out.relative_to(ROOT)}: {out.stat().st_size // 1024} KB")


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# study.csv's variant name: (label on the plot, its offset in points)
SHORT = {"reference": ("reference", -60, 8), "cg2": ("coarse grain", 8, 0),
         "mlcg": ("2 levels, z <= 12 cm", -40, 12), "mlcg_small": ("2 levels, z <= 6 cm", 6, -14),
         "mlcg3": ("3 levels", -20, 12)}


def accuracy():
    plt = pyplot()
    ours = read_csv(ROOT / "cases/silo_paper/results/study.csv")
    paper = read_csv(DATA / "paper_table2.csv")
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for r in ours:
        cost = 1.0 / float(r["speedup_cpu"])
        ax.errorbar(cost, float(r["error_pct"]), yerr=float(r["error_ci_pct"]), fmt="o", color="C0",
                    capsize=4)
        label, dx, dy = SHORT.get(r["name"], (r["name"], 6, 4))
        ax.annotate(label, (cost, float(r["error_pct"])), textcoords="offset points", xytext=(dx, dy),
                    fontsize=8, color="C0")
    for r in paper:
        cost = 1.0 / float(r["speedup"])
        ax.plot(cost, float(r["error_pct"]), "s", color="C3", mfc="none")
        ax.annotate("paper: " + r["run"], (cost, float(r["error_pct"])), textcoords="offset points",
                    xytext=(6, -12), fontsize=8, color="C3")
    ax.plot([], [], "o", color="C0", label="MLCG runs, cases/silo_paper (error +- 95 % CI)")
    ax.plot([], [], "s", color="C3", mfc="none", label="Queteschiner et al. 2017, Table 2")
    ax.axhline(0, color="0.6", lw=0.8)
    ax.axhspan(-2.5, 2.5, color="0.9", zorder=0)
    ax.set_xscale("log")
    ax.set_xlim(right=3)
    ax.set_xlabel("CPU time / the reference's CPU time (paper: 1 / its speedup)")
    ax.set_ylabel("error of mean discharge rate [%]")
    ax.set_title("silo_paper (187,504 particles): error against cost")
    ax.legend(fontsize=8, loc="center right")
    fig.tight_layout()
    save(fig, "accuracy_silo_paper.png")


def speed():
    plt = pyplot()
    rows = read_csv(DATA / "bench_speed.csv")
    sweep = read_csv(DATA / "bench_sweep.csv")
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4.2))
    labels = [f"{r['scene']}\n{r['ranks']} rank(s)" for r in rows]
    x = range(len(rows))
    a.bar([i - 0.2 for i in x], [float(r["mlcg_per_core"]) for r in rows], 0.4, label="MLCG")
    a.bar([i + 0.2 for i in x], [float(r["liggghts_per_core"]) for r in rows], 0.4, label="LIGGGHTS 3.8.0")
    for i, r in zip(x, rows):
        a.text(i, float(r["mlcg_per_core"]) * 1.02, f"{float(r['ratio']):.2f}x", ha="center", fontsize=8)
    a.set_xticks(list(x), labels, fontsize=8)
    a.set_ylabel("particle-steps/s per core")
    a.set_title("silo scenes, 29,451 particles (label: MLCG / LIGGGHTS)", fontsize=10)
    a.legend(fontsize=8)
    for ranks, style in (("1", "o-"), ("2", "s--")):
        pts = [r for r in sweep if r["ranks"] == ranks]
        b.plot([int(r["particles"]) for r in pts], [float(r["mlcg_per_core"]) for r in pts], style,
               label=f"{ranks} rank(s)")
    b.set_xscale("log")
    b.set_ylim(0, None)
    b.set_xlabel("particles (copies of one settled 30,000-particle tile)")
    b.set_ylabel("particle-steps/s per core")
    b.set_title("size sweep", fontsize=10)
    b.legend(fontsize=8)
    r0 = rows[0]
    fig.suptitle(f"mlcg_bench at {r0['commit']}, {r0['date']} {r0['time_utc']} UTC, {r0['host']}", fontsize=9)
    fig.tight_layout()
    save(fig, "speed_vs_liggghts.png")


VALUE = re.compile(r"([-+]?[0-9.]+) ± ([0-9.]+)")


def study_rows(md):
    """(label, mdot, ci, error, error_ci) of each variant row of a study.md table."""
    out = []
    for line in md.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 6 or not VALUE.match(cells[2]):
            continue
        m, ci = map(float, VALUE.match(cells[2]).groups())
        e, eci = map(float, VALUE.match(cells[5]).groups())
        out.append((cells[0].replace(" (reused)", ""), m, ci, e, eci))
    return out


def hopper():
    plt = pyplot()
    res = ROOT / "cases/hoppers/results"
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4.2))
    rows = study_rows(res / "steep_cone.md")
    for i, (label, m, ci, _, _) in enumerate(rows):
        a.errorbar(i, m, yerr=ci, fmt="o", capsize=5, color=f"C{i}")
    a.set_xticks(range(len(rows)), [r[0] for r in rows], fontsize=7)
    a.set_xlim(-0.5, len(rows) - 0.5)
    a.set_ylabel("mean discharge rate at the outlet probe [kg/s]")
    a.set_title("steep_cone: outlet rate +- 95 % CI", fontsize=10)
    scenes = sorted(p.stem for p in res.glob("*.md"))
    for k, scene in enumerate(scenes):
        r = study_rows(res / f"{scene}.md")
        for j, style in ((1, "s"), (2, "o")):
            b.errorbar(k + (j - 1.5) * 0.3, r[j][3], yerr=r[j][4], fmt=style, capsize=3,
                       color="C1" if j == 1 else "C2", label=r[j][0] if k == 0 else None)
    b.axhline(0, color="0.6", lw=0.8)
    b.axhspan(-3, 3, color="0.9", zorder=0)
    b.set_xticks(range(len(scenes)), scenes, fontsize=7, rotation=20)
    b.set_ylabel("error against the reference [%]")
    b.set_title("the six hoppers (cases/hoppers)", fontsize=10)
    b.legend(fontsize=8)
    fig.tight_layout()
    save(fig, "hopper_steep_cone.png")


def paraview():
    src = ROOT / "cases/silo_small/results/silo_small_mlcg_paraview.png"
    IMG.mkdir(parents=True, exist_ok=True)
    out = IMG / "silo_small_paraview.png"
    shutil.copyfile(src, out)
    print(f"{out.relative_to(ROOT)}: {out.stat().st_size // 1024} KB (copied from {src.relative_to(ROOT)})")


FIGURES = {"accuracy": accuracy, "speed": speed, "hopper": hopper, "paraview": paraview}

if __name__ == "__main__":
    names = sys.argv[1:]
    if len(names) != 1 or names[0] not in list(FIGURES) + ["all"]:
        sys.exit(__doc__)
    for name in FIGURES if names[0] == "all" else names:
        FIGURES[name]()
