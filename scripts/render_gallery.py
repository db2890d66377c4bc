"""Render the synthesis gallery and the seam close-up for the docs.

Usage::

    python scripts/render_gallery.py [--out docs/images] [--only gallery|seams] [--seed S]

Writes, under ``--out``:

* ``gallery_<sketch>_<example>.png`` for three sketch/example pairs: the
  sketch, the synthesized heightmap (terrain colours under a hillshade) and
  a 3D view (pyvista, off screen, vertical exaggeration 2x), side by side,
  at most 1200 px wide;
* ``seams_closeup.png``: a 160x160-cell crop of the hillshade around the
  place where plain pasting leaves its strongest seams, enlarged 3x (nearest
  neighbour), for the four merge settings (paste, graph cut, graph cut +
  Poisson, graph cut + C1) on the same sketch, example and seed, as a 2x2
  grid.

The colours, hillshade and PNG files come from
:mod:`terrasynth_core.pictures`, the off-screen pyvista view from
``terrasynth_app.views.render_3d``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

from terrasynth_app.views.render_3d import render_terrain
from terrasynth_core.examples import builtin_example
from terrasynth_core.features import read_sketch
from terrasynth_core.pictures import compose, grey_hillshade, save_png, shaded_relief, terrain_colours
from terrasynth_core.pictures import fit_panel as _fit
from terrasynth_core.pictures.sheet import MARGIN
from terrasynth_core.synthesis import Session, SynthesisParams

REPO = Path(__file__).resolve().parents[1]
SKETCH_DIR = REPO / "resources" / "sketches"

#: (sketch file, built-in example, output shape or None for the sketch's own).
GALLERY = (
    ("y_junction_512.png", "white-mountains", None),
    ("ring_cross_512.png", "big-tujunga", None),
    ("s_valley_1000.png", "himalaya", (600, 600)),
)
SEAM_SKETCH = "s_valley_1000.png"
SEAM_EXAMPLE = "white-mountains"
SEAM_SHAPE = (512, 512)
SEAM_SETTINGS = (
    ("paste", {"seam": "paste", "blend": "none"}),
    ("graph cut", {"seam": "cut", "blend": "none"}),
    ("graph cut + Poisson (paper)", {"seam": "cut", "blend": "poisson"}),
    ("graph cut + C1 (default)", {"seam": "cut", "blend": "c1"}),
)
CROP = 160
ZOOM = 3

MAX_WIDTH = 1200
MAX_BYTES = 700_000
PANEL = (MAX_WIDTH - 4 * MARGIN) // 3
EXAGGERATION = 2.0
#: Camera direction: degrees from south towards east (negative = west) and
#: above the horizon.
VIEW_AZIMUTH = -30.0
VIEW_ELEVATION = 35.0


# -- products -----------------------------------------------------------------
def render_gallery(out: Path, *, seed: int) -> None:
    """Synthesize each ``GALLERY`` pair and save its three-panel PNG in ``out``."""
    for sketch_file, key, shape in GALLERY:
        sketch = read_sketch(SKETCH_DIR / sketch_file)
        example = builtin_example(key).load()
        t = time.perf_counter()
        result = Session([example], sketch, shape=shape, params=SynthesisParams(seed=seed)).run()
        seconds = time.perf_counter() - t
        shown_sketch = sketch.resized(result.heights.shape) if shape else sketch
        cell = example.cell_size or (1.0, 1.0)
        panels = [
            _fit(shown_sketch.to_rgb(), PANEL),
            _fit(shaded_relief(result.heights, cell_size=cell)[..., :3], PANEL),
            Image.fromarray(render_terrain(result.heights, terrain_colours(result.heights), cell_size=cell,
                                           size=(PANEL, PANEL), exaggeration=EXAGGERATION,
                                           azimuth=VIEW_AZIMUTH, elevation=VIEW_ELEVATION)),
        ]
        rows, cols = result.heights.shape
        relief = float(result.heights.max() - result.heights.min())
        labels = [
            "sketch (red ridge, blue valley)",
            "synthesized heightmap, hillshade",
            f"3D, vertical exaggeration {EXAGGERATION:g}x",
        ]
        title = (f"{Path(sketch_file).stem} on {key}: {rows}x{cols} cells, "
                 f"relief {relief:.0f} m, {seconds:.1f} s")
        path = out / f"gallery_{Path(sketch_file).stem}_{key}.png"
        size = save_png(compose(panels, labels, title, columns=3), path, max_bytes=MAX_BYTES).stat().st_size
        print(f"wrote {path} ({size // 1000} KB): {title}", flush=True)


def _seam_window(result) -> tuple[int, int]:
    """Top-left corner of the ``CROP`` window with the most |Laplacian| on
    patch boundaries, wholly inside the output."""
    pid = result.patch_id
    edge = np.zeros(pid.shape, dtype=bool)
    edge[1:, :] |= pid[1:, :] != pid[:-1, :]
    edge[:, 1:] |= pid[:, 1:] != pid[:, :-1]
    strength = np.where(edge, np.abs(ndimage.laplace(result.heights.astype(np.float64))), 0.0)
    density = ndimage.uniform_filter(strength, CROP, mode="constant")
    half = CROP // 2
    inner = density[half:-half, half:-half]
    r, c = np.unravel_index(int(np.argmax(inner)), inner.shape)
    return int(r), int(c)


def render_seams(out: Path, *, seed: int) -> None:
    """Synthesize ``SEAM_SKETCH`` with each merge setting and save the close-up grid."""
    sketch = read_sketch(SKETCH_DIR / SEAM_SKETCH)
    example = builtin_example(SEAM_EXAMPLE).load()
    cell = example.cell_size or (1.0, 1.0)
    results = []
    for _, options in SEAM_SETTINGS:
        params = SynthesisParams(seed=seed, **options)
        results.append(Session([example], sketch, shape=SEAM_SHAPE, params=params).run())
    r0, c0 = _seam_window(results[0])
    panels = []
    for result in results:
        shade = grey_hillshade(result.heights, cell_size=cell)[r0:r0 + CROP, c0:c0 + CROP]
        panels.append(Image.fromarray(shade).resize((CROP * ZOOM, CROP * ZOOM), Image.NEAREST).convert("RGB"))
    labels = [name for name, _ in SEAM_SETTINGS]
    title = (f"Seams: {Path(SEAM_SKETCH).stem} at {SEAM_SHAPE[0]}x{SEAM_SHAPE[1]} on {SEAM_EXAMPLE}, seed {seed}; "
             f"cells {r0}-{r0 + CROP} x {c0}-{c0 + CROP}, hillshade, {ZOOM}x")
    path = out / "seams_closeup.png"
    size = save_png(compose(panels, labels, title, columns=2), path, max_bytes=MAX_BYTES).stat().st_size
    print(f"wrote {path} ({size // 1000} KB): {title}", flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "images", help="output folder")
    parser.add_argument("--only", choices=["gallery", "seams"], default=None, help="render only one product")
    parser.add_argument("--seed", type=int, default=0, help="synthesis seed (default 0)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "gallery"):
        render_gallery(args.out, seed=args.seed)
    if args.only in (None, "seams"):
        render_seams(args.out, seed=args.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
