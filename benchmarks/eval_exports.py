"""Round trips of every export: written by TerraSynth, read back by a real reader.

Usage::

    python benchmarks/eval_exports.py [--example builtin:white-mountains] [--size 1009]

The example is resampled once to square cells and cut to a ``size`` x
``size`` square, so no preset has to resample it and the table measures the
files alone.  Each row writes it, reads it back with the reader an engine
or tool would use (Pillow for PNG, numpy for ``.r16``, the OpenEXR
bindings, rasterio for GeoTIFF, trimesh for GLB), turns the values into
metres *the way the engine does* (Unreal: ``Location.Z + (level - 32768)
Scale.Z / 128`` with the printed scales; Unity: ``position + level / 65535
height``) and prints the largest error in metres next to one 16-bit step
(the height range / 65535).  The last table compares our flow accumulation
(:mod:`terrasynth_core.export.hydrology`) with RichDEM's (the ``bench``
extra) on the same grid: the share of each one's stream cells within 0, 1
and 3 cells of the other's.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import OpenEXR  # noqa: E402
import rasterio  # noqa: E402
import trimesh  # noqa: E402
from PIL import Image  # noqa: E402

from terrasynth_core.examples import resolve_dem  # noqa: E402
from terrasynth_core.export import export_for_engine  # noqa: E402
from terrasynth_core.export.engines import engine_ready, unity_heights_m, unreal_heights_m  # noqa: E402
from terrasynth_core.export.hydrology import flow_accumulation  # noqa: E402
from terrasynth_core.io import save_dem, save_mesh  # noqa: E402


def _png(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        return np.asarray(image).astype(np.int64)


def round_trips(field, folder: Path) -> list[tuple[str, str, float]]:
    """(format, reader, max error in metres) for every export of ``field``."""
    truth = field.heights.astype(np.float64)
    rows = []
    done = export_for_engine(field, "unreal", folder / "unreal")
    rows.append(("unreal 16-bit PNG", "Pillow + Unreal's Z formula",
                 np.abs(unreal_heights_m(_png(folder / "unreal" / "terrain.png"), done.settings) - truth).max()))
    n = field.shape[0]
    if n in (253, 505, 1009, 2017, 4033):
        tile = (n - 1) // 2 + 1
        done = export_for_engine(field, "unreal", folder / "tiles", size=tile, tiles=2)
        t = {(i, j): unreal_heights_m(_png(folder / "tiles" / f"terrain_x{i}_y{j}.png"), done.settings)
             for i in range(2) for j in range(2)}
        whole = np.block([[t[0, 0], t[1, 0][:, 1:]], [t[0, 1][1:], t[1, 1][1:, 1:]]])
        rows.append(("unreal 2 x 2 tiles", "Pillow + Unreal's Z formula", np.abs(whole - truth).max()))
    unity = field.window(0, 1025, 0, 1025) if n >= 1025 else field.window(0, 513, 0, 513)
    done = export_for_engine(unity, "unity", folder / "unity")
    side = unity.shape[0]
    raw = np.fromfile(folder / "unity" / "terrain.r16", dtype="<u2").reshape(side, side)
    # In steps of the whole field's range: this window's own range is smaller.
    rows.append((f"unity .r16 ({side} x {side} corner)", "numpy <u2 + Unity's height",
                 np.abs(unity_heights_m(raw, done.settings) - unity.heights).max()))
    export_for_engine(field, "godot", folder / "godot")
    with OpenEXR.File(str(folder / "godot" / "terrain.exr")) as exr:
        back = np.array(exr.channels()["Y"].pixels, dtype=np.float64)
    rows.append(("godot/blender/houdini EXR", "OpenEXR", np.abs(back - truth).max()))
    save_dem(field, folder / "t.tif")
    with rasterio.open(folder / "t.tif") as ds:
        rows.append(("GeoTIFF float32", "rasterio", np.abs(ds.read(1).astype(np.float64) - truth).max()))
    save_mesh(field, folder / "t.glb")
    (mesh,) = trimesh.load(folder / "t.glb", process=False).geometry.values()
    dy, dx = field.cell_size
    r = np.rint((-mesh.vertices[:, 2]) / dy).astype(int)
    c = np.rint(mesh.vertices[:, 0] / dx).astype(int)
    heights_at = truth[field.shape[0] - 1 - r, c]
    rows.append(("GLB mesh vertices", "trimesh", np.abs(mesh.vertices[:, 1] - heights_at).max()))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--example", default="builtin:white-mountains")
    parser.add_argument("--size", type=int, default=1009)
    args = parser.parse_args(argv)
    field, _ = engine_ready(resolve_dem(args.example))
    n = min(args.size, *field.shape)
    field = field.window(0, n, 0, n)
    step = (field.max - field.min) / 65535
    print(f"{args.example}: {n} x {n} cells of {field.cell_size[0]:.2f} m, heights {field.min:.1f} .. "
          f"{field.max:.1f} m, one 16-bit step = {step * 1000:.2f} mm")
    with tempfile.TemporaryDirectory() as tmp:
        rows = round_trips(field, Path(tmp))
    print(f"\n| export | read back with | max error (m) | in 16-bit steps |")
    print("|---|---|---|---|")
    for name, reader, error in rows:
        print(f"| {name} | {reader} | {error:.5f} | {error / step:.2f} |")
    print("(Unity's corner: its own range is smaller, so its step too; the error stays within half of it.)")

    start = time.perf_counter()
    ours = flow_accumulation(field.heights)
    seconds = time.perf_counter() - start
    try:
        from fidelity_measures import d8_accumulation
    except ImportError:
        print("\n(RichDEM not installed: install the bench extra to compare flow accumulation)")
        return 0
    theirs = d8_accumulation(field.heights)
    stream_share = 1 / 2000
    ours_streams, their_streams = ours >= stream_share * ours.size, theirs >= stream_share * theirs.size
    # Flats are drained differently (RichDEM: an epsilon gradient; ours: the
    # shortest path to the spill), so a stream may cross a filled lake a cell
    # or two aside: the measure is the share of stream cells near the other's.
    from scipy import ndimage

    near_theirs = ndimage.distance_transform_edt(~their_streams)[ours_streams]
    near_ours = ndimage.distance_transform_edt(~ours_streams)[their_streams]
    print(f"\nflow accumulation on this grid, ours ({seconds:.2f} s) against RichDEM's "
          "(priority-flood + epsilon, D8); streams: >= 1/2000 of the cells")
    print("| within | of our stream cells near RichDEM's | of RichDEM's near ours |")
    print("|---|---|---|")
    shares = {}
    for cells in (0, 1, 3):
        shares[cells] = (float((near_theirs <= cells).mean()), float((near_ours <= cells).mean()))
        print(f"| {cells} cells | {100 * shares[cells][0]:.1f} % | {100 * shares[cells][1]:.1f} % |")
    print(f"largest catchment: ours {int(ours.max())} cells, RichDEM {int(np.max(theirs))}")
    print(json.dumps({"rows": [(a, b, float(c)) for a, b, c in rows], "step_m": step, "stream_shares": shares}),
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
