"""Renders a multi-level run's particles with ParaView: every level's snapshot at one time, spheres of
their radius, coloured by speed |v|, cut open at y = 0 to show the inside.

    xvfb-run -a -s "-screen 0 1600x1600x24" pvbatch scripts/render_paraview.py RUN_DIR --time T --out PNG

Debian's ParaView renders through X only, hence xvfb-run (scripts/setup.sh installs ParaView,
--with-paraview adds xvfb). RUN_DIR is a hierarchy's run folder (levels/<name>/particles.xmf) or a single
level's. Files are read with ParaView's XDMF 3 reader (Xdmf3ReaderS), the snapshot nearest T taken on
each level (they must agree within --tolerance). Inside a fine region both levels hold particles (the
coarse level goes on there); the picture shows the finest level there and the coarser level only
outside its regions, whose boxes are drawn as outlines.
"""
import argparse
import ctypes
import json
import os
import sys
import tomllib
from pathlib import Path

# Under xvfb-run, Debian's ParaView 5.11 aborted at its first render window with "bad X server
# connection" in about half the tries on this machine (pvpython and pvbatch alike, the X server up and
# answering xdpyinfo), and in none of 5 after the process had opened the display once before importing
# ParaView. Not understood; kept because it works.
_x11 = ctypes.CDLL("libX11.so.6")
_x11.XOpenDisplay.restype = ctypes.c_void_p
_display = _x11.XOpenDisplay(None)
if not _display:
    sys.exit("render_paraview: cannot open the X display (run it under xvfb-run, see the usage above)")

from paraview import simple  # noqa: E402


def snapshot_time(level_dir, want):
    entries = json.loads((level_dir / "particles" / "index.json").read_text())["entries"]
    return min((e["time"] for e in entries), key=lambda t: abs(t - want))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", type=Path)
    ap.add_argument("--time", type=float, required=True, help="simulated time [s] of the snapshot to show")
    ap.add_argument("--out", type=Path, required=True, help="PNG to write")
    ap.add_argument("--size", type=int, nargs=2, default=[900, 1000], help="image width and height [px]")
    ap.add_argument("--tolerance", type=float, default=1e-3, help="largest time difference between levels [s]")
    ap.add_argument("--speed-max", type=float, default=0.0, help="top of the colour scale [m/s]; 0 = the largest")
    ap.add_argument("--title", default="")
    ap.add_argument("--colors", type=int, default=0,
                    help="reduce the PNG to this many colours (Pillow), for a smaller file; 0 = keep")
    ap.add_argument("--zoom", type=float, default=1.25, help="camera dolly after fitting everything in view")
    a = ap.parse_args()

    run = a.run.resolve()
    levels = sorted((run / "levels").glob("*/particles.xmf")) if (run / "levels").is_dir() else []
    levels = [x.parent for x in levels] or [run]
    # Each level's own summary.json (written at every checkpoint, so a run still going can be drawn).
    summaries = {d.name: json.loads((d / "summary.json").read_text()) for d in levels}
    alpha = {name: s["levels"][0].get("alpha", 1.0) for name, s in summaries.items()}
    summary = next(iter(summaries.values()))
    order = sorted(levels, key=lambda d: -alpha.get(d.name, 1.0))  # coarsest first
    case = tomllib.loads((order[-1] / "case.toml").read_text())
    regions = case.get("coupling", {}).get("regions", [])

    view = simple.CreateView("RenderView")
    view.ViewSize = a.size
    view.OrientationAxesVisibility = 0
    view.Background = [1.0, 1.0, 1.0]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    lut = simple.GetColorTransferFunction("speed")
    lut.ApplyPreset("Turbo" if "Turbo" in simple.GetLookupTableNames() else "Jet", True)

    times, top_speed, shown = {}, 0.0, []
    for level in order:
        t = snapshot_time(level, a.time)
        times[level.name] = t
        reader = simple.Xdmf3ReaderS(FileName=[str(level / "particles.xmf")])
        reader.UpdatePipelineInformation()
        data = simple.ForceTime(Input=reader, ForcedTime=t, IgnorePipelineTime=1)
        speed = simple.Calculator(Input=data, ResultArrayName="speed", Function="mag(velocity)")
        cut = simple.Clip(Input=speed, ClipType="Plane")  # keeps y >= 0: the far half, its cut face seen from -y
        cut.ClipType.Origin = [0.0, 0.0, 0.0]
        cut.ClipType.Normal = [0.0, 1.0, 0.0]
        cut.Invert = 0
        cut.Crinkleclip = 1
        part = cut
        if level != order[-1]:  # a coarser level: hide it inside the finer level's regions
            for r in regions:
                if r.get("coarse") != level.name:
                    continue
                box = simple.Clip(Input=part, ClipType="Box")
                lo, hi = r["min"], r["max"]
                box.ClipType.Position = lo
                box.ClipType.Length = [hi[i] - lo[i] for i in range(3)]
                box.Invert = 0  # keep what lies outside the box
                box.Crinkleclip = 1
                part = box
        glyph = simple.Glyph(Input=part, GlyphType="Sphere")
        glyph.ScaleArray = ["POINTS", "radius"]
        glyph.ScaleFactor = 2.0  # the unit sphere source has diameter 1
        glyph.GlyphMode = "All Points"
        glyph.OrientationArray = ["POINTS", "No orientation array"]
        glyph.GlyphType.ThetaResolution = 12
        glyph.GlyphType.PhiResolution = 8
        glyph.UpdatePipeline(t)
        part.UpdatePipeline(t)
        rng = speed.PointData["speed"].GetRange() if "speed" in speed.PointData.keys() else (0.0, 0.0)
        top_speed = max(top_speed, rng[1])
        d = simple.Show(glyph, view)
        simple.ColorBy(d, ("POINTS", "speed"))
        d.LookupTable = lut
        d.Specular = 0.3
        shown.append((level.name, part))

    if max(times.values()) - min(times.values()) > a.tolerance:
        print(f"render_paraview: the levels' snapshots nearest {a.time} s differ: {times}", file=sys.stderr)
        return 1
    for r in regions:
        lo, hi = r["min"], r["max"]
        box = simple.Box(XLength=hi[0] - lo[0], YLength=hi[1] - lo[1], ZLength=hi[2] - lo[2],
                         Center=[(hi[i] + lo[i]) / 2 for i in range(3)])
        o = simple.Show(simple.Outline(Input=box), view)
        o.AmbientColor = o.DiffuseColor = [0.2, 0.2, 0.2]
        o.LineWidth = 2.0

    lut.RescaleTransferFunction(0.0, a.speed_max or max(top_speed, 1e-6))
    bar = lut.GetScalarBar(view) if hasattr(lut, "GetScalarBar") else simple.GetScalarBar(lut, view)
    bar.Title = "speed [m/s]"
    bar.RangeLabelFormat = "%.2g"
    bar.LabelFormat = "%.2g"
    bar.ComponentTitle = ""
    bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]
    bar.WindowLocation = "Any Location"
    bar.Orientation = "Horizontal"
    bar.Position = [0.30, 0.03]
    bar.ScalarBarLength = 0.40
    bar.Visibility = 1

    t = sum(times.values()) / len(times)
    names = ", ".join(f"{d.name} (alpha {alpha.get(d.name, 1.0):g})" for d in order)
    fired = [f"{e['name']} at {e['time']:.2f} s" for e in summary.get("events", []) if e.get("fired")]
    when = f"t = {t:.2f} s" + (f" ({', '.join(fired)})" if fired else "")
    title = a.title or (f"{summary.get('title', run.name)}, {when}\n{names}; cut open at y = 0"
                        + ("; outlined: fine region" if regions else ""))
    text = simple.Text(Text=title)
    td = simple.Show(text, view)
    td.WindowLocation = "Upper Center"
    td.FontSize = 16
    td.Color = [0.1, 0.1, 0.1]

    view.CameraPosition = [0.0, -1.0, 0.35]
    view.CameraFocalPoint = [0.0, 0.0, 0.17]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    simple.ResetCamera(view)
    view.CameraParallelProjection = 0
    cam = simple.GetActiveCamera()
    cam.Dolly(a.zoom)
    simple.Render(view)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    simple.SaveScreenshot(str(a.out), view, ImageResolution=a.size, CompressionLevel="9")
    if a.colors:
        from PIL import Image  # python3-pil, a dependency of python3-matplotlib (scripts/setup.sh)
        Image.open(a.out).convert("RGB").quantize(colors=a.colors, method=Image.Quantize.FASTOCTREE,
                                                  dither=Image.Dither.FLOYDSTEINBERG).save(a.out, optimize=True)
    counts = {n: p.GetDataInformation().GetNumberOfPoints() for n, p in shown}
    print(f"render_paraview: {a.out} ({a.size[0]}x{a.size[1]}), snapshots at {times}, "
          f"particles drawn {counts}, speed scale 0 .. {a.speed_max or top_speed:.3g} m/s", flush=True)
    return 0


if __name__ == "__main__":
    code = main()
    sys.stdout.flush()
    # ParaView's teardown under xvfb-run ended in SIGSEGV here after the PNG was written; skip it.
    os._exit(code)
