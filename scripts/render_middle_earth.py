"""Render the README pictures of the Middle-earth demo.

Usage::

    python scripts/render_middle_earth.py [--out docs/images] [--seed S] [--size ROWSxCOLS]

Synthesizes the demo (``resources/sketches/middle_earth*``, see
``scripts/make_middle_earth.py``) and writes, under ``--out``:

* ``middle_earth_map.png``: the input (style regions in their flat
  colours, water in blue, ridge and valley strokes, the stamp's footprint
  and the pins) beside the result (elevation colours under a hillshade,
  water in blue by depth), at most 1200 px wide;
* ``middle_earth_3d.png``: an off-screen pyvista view of the result from
  the south-east, vertical exaggeration 2.5x, water in blue.

Both are kept under 400 KB (quantized to 256 colours when needed).  The
output has no single cell size (the examples' range from 30 m to 93 m);
the pictures use 90 m, that of most of the SRTM examples.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from make_middle_earth import STYLES, demo_params, load_demo
from render_gallery import MARGIN, MAX_WIDTH, compose
from terrasynth_app.views.render_3d import render_terrain
from terrasynth_core.cli.main import parse_size
from terrasynth_core.pictures import SHALLOW_RGB, depth_colours, hillshade, lit, save_png, terrain_colours
from terrasynth_core.synthesis import Session

REPO = Path(__file__).resolve().parents[1]
#: Cell size the pictures assume, metres (see the module docstring).
CELL = (90.0, 90.0)
EXAGGERATION = 2.5
#: Camera: degrees from south towards east, and above the horizon.
VIEW_AZIMUTH = 25.0
VIEW_ELEVATION = 38.0
MAX_BYTES = 400_000
STAMP_RGB = (255, 140, 0)
PIN_RGB = (255, 230, 0)


# -- colours --------------------------------------------------------------------
def map_colours(heights: np.ndarray, water: np.ndarray, level: float) -> np.ndarray:
    """Elevation colours on land (spanning the land's heights), blues by
    depth in water; float (rows, cols, 3) in [0, 255]."""
    land = np.where(water, np.nan, heights.astype(np.float64))
    rgb = terrain_colours(land).astype(np.float64)
    if water.any():
        rgb[water] = depth_colours(level - heights[water])
    return rgb


def shaded_map(heights: np.ndarray, water: np.ndarray, level: float) -> np.ndarray:
    """Map colours darkened by a north-west hillshade of the terrain with
    the water surface flat, uint8 (rows, cols, 3)."""
    surface = np.where(water, np.float32(level), heights)
    return lit(map_colours(heights, water, level), hillshade(surface, cell_size=CELL))


def input_map(controls, sketch, colours: list[str], stamp_bbox) -> Image.Image:
    """Style colours (``"#rrggbb"`` of style 0, 1, ...), water, strokes,
    the stamp's footprint and the pins."""
    palette = np.array([_rgb(c) for c in colours], np.uint8)
    rgb = palette[controls.style_map].copy()
    rgb[controls.water.mask] = SHALLOW_RGB.astype(np.uint8)
    rgb[sketch.ridge_mask] = (220, 0, 0)
    rgb[sketch.valley_mask] = (0, 40, 230)
    img = Image.fromarray(rgb)
    draw = ImageDraw.Draw(img)
    if stamp_bbox is not None:
        r0, r1, c0, c1 = stamp_bbox
        draw.rectangle((c0, r0, c1 - 1, r1 - 1), outline=STAMP_RGB, width=3)
    for p in controls.pins:
        draw.ellipse((p.col - 7, p.row - 7, p.col + 7, p.row + 7), fill=PIN_RGB, outline=(0, 0, 0), width=2)
    return img


def _rgb(hex_colour: str) -> tuple[int, int, int]:
    return tuple(int(hex_colour[i:i + 2], 16) for i in (1, 3, 5))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="output folder")
    parser.add_argument("--seed", type=int, default=0, help="synthesis seed (default 0)")
    parser.add_argument("--size", type=parse_size, default=None, metavar="ROWSxCOLS",
                        help="output size (default the map's 768x1024)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    sketch, controls, scale = load_demo(shape=args.size)
    params = demo_params(seed=args.seed, scale=scale)
    t = time.perf_counter()
    session = Session([], sketch, params=params, controls=controls)
    result = session.run()
    seconds = time.perf_counter() - t
    for w in result.warnings:
        print(f"warning: {w}")
    heights = result.heights
    water, level = session.controls.water.mask, session.controls.water.level
    stamp_bbox = next((p.bbox for p in result.patches if p.kind == "stamp"), None)
    rows, cols = heights.shape
    land = heights[~water]
    summary = (f"{rows}x{cols} cells, land {land.min():.0f} to {land.max():.0f} m, water level {level:g} m, "
               f"{seconds:.0f} s")

    panel = (MAX_WIDTH - 3 * MARGIN) // 2
    fit = [img.resize((panel, round(panel * rows / cols)), Image.LANCZOS)
           for img in (input_map(session.controls, session.sketch, [c for _, c, _ in STYLES], stamp_bbox),
                       Image.fromarray(shaded_map(heights, water, level)))]
    names = " | ".join(f"{name}: {dem.removeprefix('builtin:')}" for name, _, dem in STYLES)
    labels = ["input: style regions, water, sketch, stamp (orange), pins (yellow)",
              "result: elevation colours, hillshade, water"]
    picture = compose(fit, labels, f"Middle-earth demo: {summary}", columns=2)
    footer = Image.new("RGB", (picture.size[0], 24), "white")
    ImageDraw.Draw(footer).text((MARGIN, 4), names, fill=(60, 60, 60), font=ImageFont.load_default(size=14))
    both = Image.new("RGB", (picture.size[0], picture.size[1] + footer.size[1]), "white")
    both.paste(picture, (0, 0))
    both.paste(footer, (0, picture.size[1]))
    path = args.out / "middle_earth_map.png"
    print(f"wrote {path} ({save_png(both, path, max_bytes=MAX_BYTES).stat().st_size // 1000} KB)")

    colours = map_colours(heights, water, level)
    # The 3D view shows the water surface, not its bed.
    view = render_terrain(np.where(water, np.float32(level), heights), colours, cell_size=CELL,
                          size=(MAX_WIDTH - 2 * MARGIN, 720), exaggeration=EXAGGERATION, azimuth=VIEW_AZIMUTH,
                          elevation=VIEW_ELEVATION, zoom=1.45, trim=True)
    picture = compose([Image.fromarray(view)], [f"3D from the south-east, vertical exaggeration {EXAGGERATION:g}x, "
                                                f"{CELL[0]:g} m cells"],
                      f"Middle-earth demo in 3D: {summary}", columns=1)
    path = args.out / "middle_earth_3d.png"
    print(f"wrote {path} ({save_png(picture, path, max_bytes=MAX_BYTES).stat().st_size // 1000} KB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
