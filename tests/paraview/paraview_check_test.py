#!/usr/bin/python3
"""ctest paraview_check: ParaView's own XDMF reader opens what a run writes (issue 16).

    tests/paraview/paraview_check_test.py SOURCE_DIR BIN_DIR

Runs shortened copies of the quickstart cases in a temporary folder (single level: 500 beads, 0.1 s of
discharge; two levels: 0.15 s), then `pvpython scripts/paraview_check.py` on both run folders, which
must pass. Then breaks copies of them on purpose, one defect each, and asserts that the check exits 1
and names each damaged file with what disagreed. pvpython missing is a failure like anything else
missing (issue 34, item 10): `scripts/setup.sh` installs it (paraview, python3-paraview), so a machine
without it is not set up, and a skip would pass the suite without ever opening a file in ParaView.
Uses /usr/bin/python3 with h5py (python3-h5py, in scripts/setup.sh) to delete a dataset.
"""
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

def fail(msg):
    print(f"FAILED: {msg}")
    sys.exit(1)


def edit(text, old, new, what):
    if text.count(old) != 1:
        fail(f"{what}: expected exactly one '{old}' to replace, found {text.count(old)}")
    return text.replace(old, new)


def copy(tmp, run_name, name):
    """A copy of a run folder without its sockets (bus.ipc) and checkpoints, which the check never reads."""
    def skip(folder, names):
        return [n for n in names if n == "checkpoints" or n.endswith(".ipc") or n == "checkpoint.h5"
                or not (Path(folder) / n).is_file() and not (Path(folder) / n).is_dir()]
    shutil.copytree(tmp / run_name, tmp / name, ignore=skip)
    return tmp / name


def run(cmd, cwd, timeout=300):
    print("$ " + " ".join(str(c) for c in cmd), flush=True)
    return subprocess.run([str(c) for c in cmd], cwd=cwd, capture_output=True, text=True, timeout=timeout)


def main():
    src, bindir = Path(sys.argv[1]), Path(sys.argv[2])
    pvpython = shutil.which("pvpython")
    if not pvpython:
        fail("pvpython not found on PATH: ParaView is not installed; run scripts/setup.sh "
             "(it installs paraview and python3-paraview)")
    tmp = Path(tempfile.mkdtemp(prefix="mlcg_paraview_"))
    print(f"working in {tmp} (removed when the test passes)")
    quick = src / "cases" / "quickstart"
    single = edit((quick / "case.toml").read_text(), "count_alpha1 = 2500 ", "count_alpha1 = 500 ", "case.toml")
    single = edit(single, 'end = { event = "open", plus = 0.5 }', 'end = { event = "open", plus = 0.1 }', "case.toml")
    (tmp / "single.toml").write_text(single)
    (tmp / "case.toml").write_text((quick / "case.toml").read_text())  # the base of mlcg.toml
    (tmp / "mlcg.toml").write_text(edit((quick / "mlcg.toml").read_text(), "end = 0.6\n", "end = 0.15\n", "mlcg.toml"))
    for case, out in (("single.toml", "single"), ("mlcg.toml", "hierarchy")):
        r = run([bindir / "mlcg", "run", case, "--out", out, "--quiet"], tmp)
        if r.returncode != 0:
            fail(f"mlcg run {case} exited {r.returncode}:\n{r.stdout}{r.stderr}")

    check = src / "scripts" / "paraview_check.py"
    r = run([pvpython, check, "single", "hierarchy"], tmp)
    print(r.stdout)
    if r.returncode != 0:
        fail(f"paraview_check exited {r.returncode} on intact runs:\n{r.stderr[-3000:]}")
    want = ["single/particles.xmf", "single/grids/hopper.xmf"] + [
        f"hierarchy/levels/{lv}/{f}" for lv in ("coarse", "fine") for f in ("particles.xmf", "grids/hopper.xmf")]
    for f in want:
        if not re.search(rf"^OK   {re.escape(f)}: ", r.stdout, re.M):
            fail(f"no OK line for {f}")
    if f"{len(want)} files, 0 failed" not in r.stdout:
        fail(f"expected {len(want)} files checked")

    # One defect per copy; each must be named with its file and what disagreed.
    expect = {}
    d = copy(tmp, "single", "declared_count")  # the last snapshot's XDMF declares one particle fewer than its file holds
    x = (d / "particles.xmf").read_text()
    i = x.rfind('<Grid Name="particles_')
    n = int(re.search(r'NumberOfElements="(\d+)"', x[i:]).group(1))
    tail = x[i:].replace(f'"{n}"', f'"{n - 1}"').replace(f'"{n} 3"', f'"{n - 1} 3"')
    (d / "particles.xmf").write_text(x[:i] + tail)
    expect["declared_count/particles.xmf"] = rf"ParaView reads {n - 1} points, the HDF5 file holds {n} particles"

    d = copy(tmp, "single", "dropped_attribute")  # a grid's XDMF no longer declares max_speed, which its files hold
    x = (d / "grids" / "hopper.xmf").read_text()
    y = re.sub(r'\s*<Attribute Name="max_speed".*?</Attribute>', "", x, flags=re.S)
    if y == x:
        fail("no max_speed attribute in grids/hopper.xmf to drop")
    (d / "grids" / "hopper.xmf").write_text(y)
    expect["dropped_attribute/grids/hopper.xmf"] = r"ParaView's cell arrays \[.*\], the grid file's datasets \[.*'max_speed'.*\]"

    d = copy(tmp, "hierarchy", "deleted_dataset")  # a fine snapshot lost its omega dataset
    h5 = d / "levels" / "fine" / "particles" / "particles_000001.h5"
    r = run(["/usr/bin/python3", "-c", f"import h5py\nwith h5py.File({str(h5)!r}, 'a') as f: del f['omega']"], tmp)
    if r.returncode != 0:
        fail(f"could not delete the dataset: {r.stderr}")
    expect["deleted_dataset/levels/fine/particles.xmf"] = r"refers to particles/particles_000001\.h5:/omega, which that file does not hold"

    d = copy(tmp, "hierarchy", "deleted_file")  # a coarse grid frame is gone
    os.remove(d / "levels" / "coarse" / "grids" / "hopper" / "hopper_000002.h5")
    expect["deleted_file/levels/coarse/grids/hopper.xmf"] = r"refers to hopper/hopper_000002\.h5, which is missing"

    d = copy(tmp, "single", "wrong_total")  # summary.json disagrees with the last snapshot
    s = (d / "summary.json").read_text()
    final = int(re.search(r'"particles_final": (\d+)', s).group(1))
    (d / "summary.json").write_text(edit(s, f'"particles_final": {final}', f'"particles_final": {final + 1}', "summary.json"))
    expect["wrong_total/particles.xmf"] = rf"ParaView reads {final} points, summary.json reports particles_final {final + 1}"

    r = run([pvpython, check] + sorted({k.split("/")[0] for k in expect}), tmp)
    print(r.stdout)
    if r.returncode != 1:
        fail(f"paraview_check exited {r.returncode} on damaged runs, expected 1:\n{r.stderr[-3000:]}")
    for f, why in expect.items():
        if not re.search(rf"^FAIL {re.escape(f)}: .*{why}", r.stdout, re.M):
            fail(f"no FAIL line for {f} matching '{why}'")
    fails = re.findall(r"^FAIL ", r.stdout, re.M)
    if len(fails) != len(expect):
        fail(f"{len(fails)} FAIL lines for {len(expect)} defects: the intact files of the copies must pass")
    shutil.rmtree(tmp)
    print(f"paraview_check: intact runs pass ({len(want)} files); {len(expect)} damaged files each named")
    return 0


if __name__ == "__main__":
    sys.exit(main())
