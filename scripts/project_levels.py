#!/usr/bin/env python3
"""The paper's five-level thought experiment (Queteschiner et al. 2017, section 4), costed with
measured inputs from one MLCG run of this build.

    scripts/project_levels.py RUN_DIR [--levels 5] [--shrink 32] [--sim-time 1.7] [--cores-per-node 64]

RUN_DIR is a finished multi-level run (its summary.json and coupling/summary.json). Measured there:
the particle-steps per second per rank of its finest level (the dense outlet region: the slowest
particles to step), its coupling overhead share (the largest level's coupling work plus the coupler's
busy time over wall time), and the bus bytes per coupling interval per cell of its coupled grids.

The experiment: particles `shrink` times smaller than the run's finest (6.14e9 at full resolution for
the paper's silo and shrink 32), L levels with alpha_l = 2^(l-1), each level's particle-filled volume a
quarter of the next coarser one's, so level l holds N_full alpha_l^-3 4^(l-L) particles. The time step
scales with the particle radius (the Rayleigh time), so dt_l = dt_run alpha_l / shrink. Cells keep the
run's size in finest-level diameters of the pair they couple; bytes per cell per interval as measured.
"""
import argparse
import json
import math
import sys
from pathlib import Path


def load(run):
    s = json.loads((run / "summary.json").read_text())
    c = json.loads((run / "coupling" / "summary.json").read_text())
    levels = s["levels"]
    finest = min(levels, key=lambda l: l["alpha"])
    ranks = finest.get("performance", {}).get("ranks", 1)
    rate = finest["particle_steps_per_second"] / ranks
    cells = sum(r["cells"] for r in c["regions"])
    bytes_per_interval = sum(l["bytes_per_interval_from_level"] + l["bytes_per_interval_to_level"]
                             for l in c["levels"])
    return {
        "rate_per_rank": rate,
        "dt": finest["dt"],
        "overhead": s["coupling"]["overhead_share"],
        "bytes_per_cell": bytes_per_interval / cells,
        "cells": cells,
        "bytes_per_interval": bytes_per_interval,
        "interval": c["interval_s"],
    }


def project(m, n_levels, shrink, sim_time, n_full, phi, d_run, cell_diameters):
    d = d_run / shrink  # the finest particle diameter of the thought experiment
    dt1 = m["dt"] / shrink
    steps_per_interval = round(m["interval"] / m["dt"])
    rows, total_ps, total_bytes_per_s = [], 0.0, 0.0
    for l in range(1, n_levels + 1):
        alpha = 2 ** (l - 1)
        n = n_full * alpha ** -3 * 4.0 ** (l - n_levels)
        dt = dt1 * alpha
        ps = n * sim_time / dt
        total_ps += ps
        row = {"level": l, "alpha": alpha, "particles": n, "dt": dt, "particle_steps": ps}
        if l < n_levels:  # the grid this level shares with the next coarser one, over its own volume
            volume = n * math.pi / 6.0 * (alpha * d) ** 3 / phi
            h = cell_diameters * alpha * d
            cells = volume / h ** 3
            interval = steps_per_interval * dt
            row.update(cells=cells, bytes_per_interval=cells * m["bytes_per_cell"], interval=interval)
            total_bytes_per_s += cells * m["bytes_per_cell"] / interval
        rows.append(row)
    ref_ps = n_full * sim_time / dt1
    return rows, total_ps, ref_ps, total_bytes_per_s


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--levels", type=int, default=5)
    ap.add_argument("--shrink", type=float, default=32.0)
    ap.add_argument("--sim-time", type=float, default=1.7, help="simulated seconds (the paper's scene: 1.7)")
    ap.add_argument("--full", type=float, default=187504 * 32.0 ** 3, help="particles at full resolution")
    ap.add_argument("--phi", type=float, default=0.6, help="bulk volume fraction of the filled volume")
    ap.add_argument("--diameter", type=float, default=2.8e-3, help="the run's finest particle diameter [m]")
    ap.add_argument("--cell-diameters", type=float, default=0.02 / 2.8e-3,
                    help="cell size in diameters of a grid's finer level (the run's: 2 cm / 2.8 mm)")
    ap.add_argument("--cores-per-node", type=int, default=64)
    a = ap.parse_args()
    try:
        m = load(a.run)
    except (OSError, KeyError, ValueError) as e:
        sys.exit(f"project_levels: {a.run}: not a finished multi-level run of this build ({e})")
    rows, ps, ref_ps, bps = project(m, a.levels, a.shrink, a.sim_time, a.full, a.phi, a.diameter,
                                    a.cell_diameters)
    cpu = ps / m["rate_per_rank"] * (1.0 + m["overhead"])
    ref_cpu = ref_ps / m["rate_per_rank"]
    week = 7 * 24 * 3600.0
    print(f"measured in {a.run}: {m['rate_per_rank']:.3g} particle-steps/s per rank (finest level), "
          f"overhead {100 * m['overhead']:.1f} %, {m['bytes_per_cell']:.0f} bus bytes per cell per interval "
          f"({m['cells']} cells, {m['bytes_per_interval']:.0f} B per interval of {m['interval']:g} s)")
    print("| level | α | particles | dt [s] | particle-steps | grid cells to the coarser level | bus bytes per interval |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        grid = (f"{r['cells']:.3g} | {r['bytes_per_interval']:.3g} (every {r['interval']:.3g} s)"
                if "cells" in r else "— | —")
        print(f"| {r['level']} | {r['alpha']} | {r['particles']:.3g} | {r['dt']:.3g} | {r['particle_steps']:.3g} | {grid} |")
    n_particles = sum(r["particles"] for r in rows)
    print(f"particles in the hierarchy {n_particles:.3g} (full resolution {a.full:.3g}: {a.full / n_particles:.0f}x fewer)")
    print(f"particle-steps {ps:.3g} against {ref_ps:.3g} at full resolution: {ref_ps / ps:.0f}x fewer")
    print(f"CPU {cpu / 3600:.3g} core-hours with the measured overhead (full resolution: {ref_cpu / 3600:.3g})")
    cores = cpu / week
    print(f"one week of wall time: {cores:.0f} cores at the measured per-rank rate and perfect scaling, "
          f"{math.ceil(cores / a.cores_per_node)} node(s) of {a.cores_per_node} cores")
    per_wall_s = bps * a.sim_time / week
    print(f"bus: {bps:.3g} bytes per simulated second over all grids; run in one week, "
          f"{per_wall_s / 1e6:.3g} MB per wall second")

if __name__ == "__main__":
    main()
