#!/usr/bin/python3
"""The drum's analysis scripts on snapshots of known answer (synthetic beds written as a run's particles/):

- scripts/drum_angle.py: a bed filling the circular segment under a chord tilted at 30 degrees reads 30;
- scripts/drum_layer.py: a bed under a chord tilted 30 degrees whose downslope velocity is U down to 2 mm
  below the chord, then falls by omega per metre of depth, reads a layer U / omega + 2 mm thick, a surface
  velocity U and a bulk rate omega; a slice of that bed with --angle 30 the same;
- scripts/drum_segregation.py: small beads in the inner disk of a full section and large ones in the ring
  around it read S = (2/3 (b^3 - a^3) / (b^2 - a^2) - 2a/3) / (2b/3); the same beads mixed read about 0; the
  same bed split over two levels (--hierarchy: fine beads in a region, coarse parcels of 8 beads outside) the same.

  tests/scripts/test_drum_scripts.py SOURCE_DIR
"""
import json
import math
import os
import re
import subprocess
import sys
import tempfile

import h5py
import numpy as np

SRC = sys.argv[1]
R = 0.04  # drum radius [m]
rng = np.random.default_rng(3)
failures = []


def write_run(folder, beds):
    """beds: list of (time, positions (N x 3), radii (N)[, velocities (N x 3)])."""
    os.makedirs(os.path.join(folder, "particles"))
    entries = []
    for i, bed in enumerate(beds):
        t, x, r = bed[:3]
        with h5py.File(os.path.join(folder, "particles", "particles_%06d.h5" % i), "w") as f:
            f["position"] = x
            f["radius"] = r
            if len(bed) > 3:
                f["velocity"] = bed[3]
        entries.append({"time": t, "index": i})
    with open(os.path.join(folder, "particles", "index.json"), "w") as f:
        json.dump({"base": "particles", "entries": entries}, f)


def disk(n, a, b):
    """n points uniform in the ring a <= rho < b of the (x, z) plane, y in the drum's length."""
    rho = np.sqrt(rng.uniform(a * a, b * b, n))
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    return np.column_stack([rho * np.cos(phi), rng.uniform(-0.01, 0.01, n), rho * np.sin(phi)])


def run(script, folder, *args):
    out = subprocess.run(["/usr/bin/python3", os.path.join(SRC, "scripts", script), folder, *args],
                         capture_output=True, text=True)
    if out.returncode != 0:
        failures.append("%s exited %d: %s" % (script, out.returncode, out.stderr.strip()))
        return ""
    return out.stdout


def expect_near(what, value, expected, tol):
    ok = abs(value - expected) <= tol
    print("%s: %.4f (expected %.4f +- %g) %s" % (what, value, expected, tol, "ok" if ok else "FAILED"))
    if not ok:
        failures.append(what)


with tempfile.TemporaryDirectory() as tmp:
    # A segment a third of the section, its chord tilted 30 degrees: the bed lies on the side the drum lifts.
    theta = math.radians(30.0)
    x = disk(600000, 0.0, R)
    n = np.array([math.sin(theta), 0.0, -math.cos(theta)])  # the chord's normal toward the bed
    bed = x[x @ n > 0.27 * R]
    beds = [(2.0 + 0.1 * k, bed, np.full(len(bed), 1e-3)) for k in range(3)]
    write_run(os.path.join(tmp, "tilted"), beds)
    m = re.search(r"dynamic angle of repose: ([-0-9.]+)", run("drum_angle.py", os.path.join(tmp, "tilted")))
    expect_near("drum_angle.py on a segment tilted 30 deg", float(m.group(1)) if m else float("nan"), 30.0, 0.2)
    # The same bed and gravity turned 20 deg about the drum's axis (a case with tilted gravity): still 30.
    phi = math.radians(20.0)
    turn = np.array([[math.cos(phi), 0.0, -math.sin(phi)], [0.0, 1.0, 0.0], [math.sin(phi), 0.0, math.cos(phi)]])
    write_run(os.path.join(tmp, "turned"), [(t, b @ turn.T, r) for t, b, r in beds])
    g = turn @ np.array([0.0, 0.0, -1.0])
    m = re.search(r"dynamic angle of repose: ([-0-9.]+)",
                  run("drum_angle.py", os.path.join(tmp, "turned"), "--gravity", "%.9f" % g[0], "%.9f" % g[2]))
    expect_near("drum_angle.py --gravity on the bed and gravity turned 20 deg", float(m.group(1)) if m else float("nan"),
                30.0, 0.2)

    # The flowing layer: 1 mm beads, centres from one radius under the chord down (the surface is the chord),
    # downslope velocity U to a = 2 mm under the chord, then U - omega (depth - a): the layer ends at a + U / omega.
    U, a_top, omega, rb = 0.015, 2e-3, 1.5, 1e-3
    depth = x @ n - 0.27 * R  # under the chord, for the positions of the tilted bed's disk
    keep = depth > rb
    beads, depth = x[keep][::15], depth[keep][::15]  # about 13,000: ~90 in a bin of the strip
    down = np.array([math.cos(theta), 0.0, math.sin(theta)])  # along the chord, toward the lower end
    if down[2] > 0.0:
        down = -down
    u = np.where(depth < a_top, U, U - omega * (depth - a_top))
    vel = u[:, None] * down[None, :]
    write_run(os.path.join(tmp, "layer"), [(2.0 + 0.1 * k, beads, np.full(len(beads), rb), vel) for k in range(3)])
    out = run("drum_layer.py", os.path.join(tmp, "layer"))
    m = re.search(r"flowing layer: ([-0-9.]+) \+- [-0-9.]+ mm .*surface velocity ([-0-9.]+) .*bulk ([-0-9.]+)", out)
    if m:
        expect_near("drum_layer.py, layer thickness [mm]", float(m.group(1)), 1e3 * (a_top + U / omega), 0.4)
        expect_near("drum_layer.py, surface velocity [m/s]", float(m.group(2)), U, 1e-4)
        expect_near("drum_layer.py, bulk rate [rad/s]", float(m.group(3)), omega, 0.02)
    else:
        failures.append("drum_layer.py printed no summary: %s" % out)
    # A fine level's slice |x| < 2.5 cm of the same bed: its own centroid tilts less, --angle gives the surface
    # (without it the surface velocity reads 0.0136 m/s).
    part = np.abs(beads[:, 0]) < 0.025
    write_run(os.path.join(tmp, "slice"), [(2.0 + 0.1 * k, beads[part], np.full(part.sum(), rb), vel[part])
                                           for k in range(3)])
    out = run("drum_layer.py", os.path.join(tmp, "slice"), "--angle", "30")
    m = re.search(r"flowing layer: ([-0-9.]+) \+- [-0-9.]+ mm .*surface velocity ([-0-9.]+)", out)
    if m:
        expect_near("drum_layer.py --angle 30 on a slice, layer thickness [mm]", float(m.group(1)),
                    1e3 * (a_top + U / omega), 0.4)
        expect_near("drum_layer.py --angle 30 on a slice, surface velocity [m/s]", float(m.group(2)), U, 1e-4)
    else:
        failures.append("drum_layer.py --angle printed no summary: %s" % out)

    # Two sizes: 1 mm beads in the inner disk a = R / sqrt(2), 1.5 mm in the ring to R (equal areas).
    a = R / math.sqrt(2.0)
    small, large = disk(30000, 0.0, a), disk(30000, a, R)
    x = np.vstack([small, large])
    r = np.concatenate([np.full(len(small), 1e-3), np.full(len(large), 1.5e-3)])
    d_s, d_l, d_all = 2.0 * a / 3.0, 2.0 / 3.0 * (R ** 3 - a ** 3) / (R ** 2 - a ** 2), 2.0 * R / 3.0
    mixed = rng.permutation(len(r))
    write_run(os.path.join(tmp, "sizes"), [(2.0, x, r), (2.1, x, r), (2.2, x, r[mixed]), (2.3, x, r[mixed])])
    out = run("drum_segregation.py", os.path.join(tmp, "sizes"))
    s = [float(v) for v in re.findall(r"S = ([-+0-9.]+)", out)]
    if len(s) == 4:
        expect_near("drum_segregation.py, small core and large ring", s[0], (d_l - d_s) / d_all, 0.01)
        expect_near("drum_segregation.py, the same beads mixed", s[2], 0.0, 0.01)
    else:
        failures.append("drum_segregation.py printed %d values of S, not 4: %s" % (len(s), out))

    # The same core-and-ring bed as a two-level run: beads in the fine level's region |x| < 2 cm, one in 8 of
    # the beads outside it as the coarse level's parcels (alpha 2: twice the radius, 8 beads each), and
    # parcels of the large size inside the region, which the coarse level holds too and --hierarchy leaves out.
    inside = np.abs(x[:, 0]) < 0.02
    out_idx = np.flatnonzero(~inside)[::8]
    ghost = disk(3000, 0.0, R)
    ghost = ghost[np.abs(ghost[:, 0]) < 0.02]
    xc = np.vstack([x[out_idx], ghost])
    rc = np.concatenate([2.0 * r[out_idx], np.full(len(ghost), 3e-3)])
    two = os.path.join(tmp, "two")
    for name, alpha, beds in (("coarse", 2.0, [(2.0, xc, rc), (2.1, xc, rc)]),
                              ("fine", 1.0, [(2.0, x[inside], r[inside]), (2.1, x[inside], r[inside])])):
        folder = os.path.join(two, "levels", name)
        write_run(folder, beds)
        with open(os.path.join(folder, "summary.json"), "w") as f:
            json.dump({"levels": [{"alpha": alpha}]}, f)
    with open(os.path.join(two, "levels", "fine", "case.toml"), "w") as f:
        f.write("[coupling]\n[[coupling.regions]]\nmin = [-0.02, -0.05, -0.05]\nmax = [0.02, 0.05, 0.05]\n")
    out = run("drum_segregation.py", two, "--hierarchy")
    s = [float(v) for v in re.findall(r"S = ([-+0-9.]+)", out)]
    if len(s) == 2:
        expect_near("drum_segregation.py --hierarchy, the core-and-ring bed on two levels", s[0],
                    (d_l - d_s) / d_all, 0.015)
    else:
        failures.append("drum_segregation.py --hierarchy printed %d values of S, not 2: %s" % (len(s), out))

if failures:
    sys.exit("FAILED: " + "; ".join(failures))
print("all passed")
