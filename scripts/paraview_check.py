"""Opens every XDMF file of MLCG run folders with ParaView's own XDMF reader and checks what it reads
against what the run wrote.

    pvpython scripts/paraview_check.py RUN_DIR [RUN_DIR ...] [--reader Xdmf3ReaderS]

RUN_DIR is a single-level run folder or a hierarchy's (its levels in levels/<name>/). Reading needs no
display: this script renders nothing. For every level folder (a folder with summary.json and
series.csv) it expects particles.xmf and grids/<name>.xmf for every [[grids]] entry of the level's
case.toml, and refuses any other .xmf/.xdmf file it cannot place. For every file and every time step
the reader offers, it compares (after checking that every HDF5 file and dataset the XDMF file refers
to exists: ParaView's XDMF 3 library aborts the process on a missing one)

- the time steps with the series' index.json (one per entry, same times);
- particles: ParaView's point count with the length of the HDF5 datasets of that snapshot (read with
  h5ls, not with the XDMF text), with series.csv's particle count at that time (when a row has that
  time) and, for the last snapshot, with summary.json's particles_final; the point arrays with the
  snapshot file's datasets less the geometry (position) and topology (connectivity);
- grids: ParaView's cell count with the cells of the HDF5 datasets and with index.json's dims, its bounds
  with index.json's origin + dims x h; the cell arrays with the grid file's datasets.

Prints one line per file (OK or FAIL and what disagreed) and exits 1 when anything disagreed (2 on a
usage error). Nothing here lists the field names: they come from the HDF5 files of the run.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tomllib
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path

from paraview import simple

GEOMETRY = {"position", "connectivity"}  # snapshot datasets XDMF maps to points and cells, not arrays


class Failure(Exception):
    pass


def h5_datasets(path):
    """{dataset name: shape} of an HDF5 file's root group, via h5ls (hdf5-tools)."""
    return dict(_h5_datasets(str(path)))


@lru_cache(maxsize=None)
def _h5_datasets(name):
    path = Path(name)
    if not path.is_file():
        raise Failure(f"{path.name} is missing")
    out = subprocess.run(["h5ls", str(path)], capture_output=True, text=True)
    if out.returncode != 0:
        raise Failure(f"h5ls {path.name}: {out.stderr.strip() or out.stdout.strip()}")
    sets = {}
    for line in out.stdout.splitlines():
        m = re.match(r"^(\S+)\s+Dataset \{([^}]*)\}", line)
        if m:
            dims = [d.strip().split("/")[0] for d in m.group(2).split(",") if d.strip()]
            sets[m.group(1)] = tuple(int(d) for d in dims)
    return tuple(sets.items())


def check_references(xmf):
    """Every HDF5 dataset the XDMF file refers to exists. ParaView's XDMF 3 library aborts the whole
    process on a missing file or dataset (it throws through the reader), so this is asked first, and
    the file is named; whether the declared sizes match is left to what ParaView reads."""
    try:
        root = ET.parse(xmf).getroot()
    except ET.ParseError as e:
        raise Failure(f"not well-formed XML: {e}")
    for item in root.iter("DataItem"):
        if item.get("Format") != "HDF":
            continue
        file, _, dataset = (item.text or "").strip().partition(":/")
        h5 = xmf.parent / file
        if not h5.is_file():
            raise Failure(f"refers to {file}, which is missing")
        if dataset not in h5_datasets(h5):
            raise Failure(f"refers to {file}:/{dataset}, which that file does not hold")


def series_counts(level_dir):
    """{time (rounded as series.csv writes it): particles} from the level's series.csv."""
    counts = {}
    path = level_dir / "series.csv"
    lines = path.read_text().splitlines()
    head = lines[0].split(",")
    ti, pi = head.index("t"), head.index("particles")
    for line in lines[1:]:
        f = line.split(",")
        counts[f[ti]] = int(f[pi])
    return counts


def open_reader(reader, path):
    make = getattr(simple, reader)
    try:
        src = make(FileName=[str(path)])
    except AttributeError:  # the XDMF 2 reader (XDMFReader) names it FileNames
        src = make(FileNames=[str(path)])
    src.UpdatePipelineInformation()
    return src


def array_names(info):
    return sorted(info.keys())


def same_time(a, b):
    return abs(a - b) <= 1e-9 * max(1.0, abs(a), abs(b))


def reader_times(src, entries, what):
    times = list(src.TimestepValues) if len(entries) > 1 else [entries[0]["time"]]
    if len(entries) > 1 and len(times) != len(entries):
        raise Failure(f"{what}: ParaView offers {len(times)} time steps, index.json lists {len(entries)}")
    for t, e in zip(times, entries):
        if not same_time(t, e["time"]):
            raise Failure(f"{what}: ParaView's time {t!r} where index.json has {e['time']!r}")
    return times


def check_particles(reader, level_dir, xmf, summary):
    series_dir = xmf.with_suffix("")
    index = json.loads((series_dir / "index.json").read_text())
    entries = index["entries"]
    if not entries:
        raise Failure("index.json lists no snapshot")
    counts = series_counts(level_dir)
    final = summary["levels"][0]["particles_final"]
    src = open_reader(reader, xmf)
    times = reader_times(src, entries, "particles")
    checked_series = 0
    for k, (t, e) in enumerate(zip(times, entries)):
        h5 = series_dir / f"{series_dir.name}_{e['index']:06d}.h5"
        sets = h5_datasets(h5)
        if "position" not in sets:
            raise Failure(f"{h5.name} has no position dataset")
        n_h5 = sets["position"][0]
        for name, shape in sets.items():
            if shape[0] != n_h5:
                raise Failure(f"{h5.name}: dataset {name} holds {shape[0]} rows, position {n_h5}")
        src.UpdatePipeline(t)
        info = src.GetDataInformation()
        n_pv = info.GetNumberOfPoints()
        where = f"t = {t:g} ({h5.name})"
        if n_pv != n_h5:
            raise Failure(f"{where}: ParaView reads {n_pv} points, the HDF5 file holds {n_h5} particles")
        if info.GetNumberOfCells() != n_h5:
            raise Failure(f"{where}: ParaView reads {info.GetNumberOfCells()} cells for {n_h5} particles")
        row = counts.get(f"{t:.6f}")
        if row is not None:
            checked_series += 1
            if row != n_pv:
                raise Failure(f"{where}: ParaView reads {n_pv} points, series.csv reports {row} particles")
        if k == len(entries) - 1 and n_pv != final:
            raise Failure(f"{where} (last): ParaView reads {n_pv} points, summary.json reports "
                          f"particles_final {final}")
        want = sorted(set(sets) - GEOMETRY)
        got = array_names(src.GetPointDataInformation())
        if got != want:
            raise Failure(f"{where}: ParaView's point arrays {got}, the snapshot's datasets {want}")
        if info.GetNumberOfCells() and array_names(src.GetCellDataInformation()):
            raise Failure(f"{where}: unexpected cell arrays {array_names(src.GetCellDataInformation())}")
    simple.Delete(src)
    n_first, n_last = entries[0]["count"], entries[-1]["count"]
    return (f"{len(times)} snapshots, first {n_first}, last {n_last} points (= HDF5; = series.csv at "
            f"{checked_series}; last = summary.json's {final}), point arrays {want}")


def check_grid(reader, xmf):
    series_dir = xmf.with_suffix("")
    index = json.loads((series_dir / "index.json").read_text())
    entries = index["entries"]
    if not entries:
        raise Failure("index.json lists no frame")
    nx, ny, nz = index["grid"]["dims"]
    h, origin = index["grid"]["h"], index["grid"]["origin"]
    src = open_reader(reader, xmf)
    times = reader_times(src, entries, "grid")
    for t, e in zip(times, entries):
        h5 = series_dir / f"{series_dir.name}_{e['index']:06d}.h5"
        sets = h5_datasets(h5)
        where = f"t = {t:g} ({h5.name})"
        shapes = {s[:3] for s in sets.values()}
        if len(shapes) != 1:
            raise Failure(f"{h5.name}: datasets of different cell shapes {sorted(shapes)}")
        cells_h5 = math.prod(shapes.pop())
        src.UpdatePipeline(t)
        info = src.GetDataInformation()
        n_pv = info.GetNumberOfCells()
        if n_pv != cells_h5:
            raise Failure(f"{where}: ParaView reads {n_pv} cells, the HDF5 datasets hold {cells_h5}")
        if n_pv != nx * ny * nz:
            raise Failure(f"{where}: ParaView reads {n_pv} cells, index.json's grid is {nx}x{ny}x{nz}")
        b = info.GetBounds()
        for axis in range(3):
            lo, hi = origin[axis], origin[axis] + (nx, ny, nz)[axis] * h
            if abs(b[2 * axis] - lo) > 1e-9 + 1e-9 * abs(lo) or abs(b[2 * axis + 1] - hi) > 1e-9 + 1e-9 * abs(hi):
                raise Failure(f"{where}: ParaView's bounds {tuple(b)}, index.json's grid spans "
                              f"axis {'xyz'[axis]} {lo} .. {hi}")
        want = sorted(sets)
        got = array_names(src.GetCellDataInformation())
        if got != want:
            raise Failure(f"{where}: ParaView's cell arrays {got}, the grid file's datasets {want}")
        if array_names(src.GetPointDataInformation()):
            raise Failure(f"{where}: unexpected point arrays {array_names(src.GetPointDataInformation())}")
    simple.Delete(src)
    return f"{len(times)} frames, {nx}x{ny}x{nz} = {nx * ny * nz} cells (= HDF5), cell arrays {want}"


def level_dirs(run):
    return sorted(p.parent for p in run.rglob("summary.json") if (p.parent / "series.csv").is_file())


def check_run(reader, run):
    """Yields (file, message or None, failure or None) for every XDMF file of the run."""
    levels = level_dirs(run)
    if not levels:
        yield run, None, "no level folder (summary.json with series.csv) in it"
        return
    top = json.loads((run / "summary.json").read_text()) if (run / "summary.json").is_file() else None
    if top is not None and run not in levels:  # a hierarchy: every level it names has its folder
        named = sorted(l["name"] for l in top.get("levels", []))
        found = sorted(d.name for d in levels if d.parent == run / "levels")
        if named != found:
            yield run, None, f"summary.json names levels {named}, levels/ holds {found}"
    placed = set()
    for level in levels:
        summary = json.loads((level / "summary.json").read_text())
        case = tomllib.loads((level / "case.toml").read_text())
        expected = [("particles", level / "particles.xmf")]
        expected += [("grid", level / "grids" / f"{g['name']}.xmf") for g in case.get("grids", [])]
        for kind, xmf in expected:
            placed.add(xmf)
            if not xmf.is_file():
                yield xmf, None, "missing (the run writes it)"
                continue
            try:
                print(f"paraview_check: reading {xmf}", file=sys.stderr, flush=True)
                check_references(xmf)
                msg = check_particles(reader, level, xmf, summary) if kind == "particles" else check_grid(reader, xmf)
                yield xmf, msg, None
            except Failure as e:
                yield xmf, None, str(e)
            except Exception as e:  # a reader error is a disagreement, not a crash of the check
                yield xmf, None, f"{type(e).__name__}: {e}"
    for xmf in sorted(list(run.rglob("*.xmf")) + list(run.rglob("*.xdmf"))):
        if xmf not in placed:
            yield xmf, None, "an XDMF file this check does not know (not a level's particles or case grid)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--reader", default="Xdmf3ReaderS",
                    help="paraview.simple reader (default Xdmf3ReaderS: our files are XDMF 3)")
    a = ap.parse_args()
    if not hasattr(simple, a.reader):
        print(f"paraview_check: ParaView {simple.GetParaViewVersion()} has no reader {a.reader}", file=sys.stderr)
        return 2
    failed = files = 0
    for run in a.runs:
        if not run.is_dir():
            print(f"paraview_check: {run} is not a folder", file=sys.stderr)
            return 2
        run = run.resolve()
        for xmf, msg, err in check_run(a.reader, run):
            files += 1
            name = os.path.relpath(xmf, run.parent)
            if err:
                failed += 1
                print(f"FAIL {name}: {err}", flush=True)
            else:
                print(f"OK   {name}: {msg}", flush=True)
    print(f"paraview_check: ParaView {simple.GetParaViewVersion()}, {a.reader}: {files} files, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
