#!/usr/bin/python3
"""The drum's analysis scripts on snapshots of known answer (synthetic beds written as a run's particles/):

- scripts/drum_angle.py: a bed filling the circular segment under a chord tilted at 30 degrees reads 30;
- scripts/drum_segregation.py: small beads in the inner disk of a full section and large ones in the ring
  around it read S = (2/3 (b^3 - a^3) / (b^2 - a^2) - 2a/3) / (2b/3); the same beads mixed read about 0.

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
    """beds: list of (time, positions (N x 3), radii (N))."""
    os.makedirs(os.path.join(folder, "particles"))
    entries = []
    for i, (t, x, r) in enumerate(beds):
        with h5py.File(os.path.join(folder, "particles", "particles_%06d.h5" % i), "w") as f:
            f["position"] = x
            f["radius"] = r
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

if failures:
    sys.exit("FAILED: " + "; ".join(failures))
print("all passed")
