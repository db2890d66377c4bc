"""Draw the Middle-earth-like demo map: style regions, water mask and sketch.

Usage::

    python scripts/make_middle_earth.py [--out resources/sketches]

Writes three 768x1024 (rows x cols) PNGs and the JSON that ties them
together, all deterministic (fixed seed, no anti-aliasing):

``middle_earth_styles.png``
    Four flat colours, one per terrain style (nearest-neighbour friendly):

    ======== ============================================ =========================
    colour   region                                       example
    ======== ============================================ =========================
    #8a6a55  high range running north-south, with a       ``builtin:himalaya``
             southern arm bending west (Misty Mountains,
             White Mountains)
    #8fbf5f  rolling hills: foothills around the range,   ``builtin:white-mountains``
             a northern upland, the east (Rhovanion)
    #e6d98c  lowland plateau: the shire, the coast and    ``builtin:gabon-plateau``
             the southern plains (under the sea too)
    #3c2323  dark volcanic land in the south-east         ``builtin:big-tujunga``
             (Mordor)
    ======== ============================================ =========================

``middle_earth_water.png``
    Black = water on white: the western sea with a gulf, one lake in the
    lowland, and one river from the western foot of the range (in the
    foothills) across the lowland into the sea, 3 to 7 cells wide.

``middle_earth_sketch.png``
    Red ridge strokes along the range's crest, its southern arm, side
    spurs, the northern upland and the two ranges fencing the volcanic land;
    blue valley strokes along the river, down two side valleys west of the
    range and along the great valley east of it (Anduin).  Strokes 4 px.

``middle_earth.json``
    What a run needs besides the PNGs (read by
    ``scripts/render_middle_earth.py`` and ``benchmarks/eval_styles.py``):

    * ``styles``: colour -> DEM (``builtin:KEY``);
    * ``water``: the mask file and the water level, **60 m**.  With the
      default bases every style sits at its example's median height, so the
      lowland lies about where its Gabon example does: a coastal plain
      (10 % of the example below 56 m) under a plateau (median 413 m).  A
      level at that 10th percentile puts the sea on the coastal plain
      without drowning the plateau;
    * ``cell_size``: **90 m**, the run's square cells (every style and the
      stamp are resampled to it);
    * ``stamp``: ``builtin:st-helens`` (the whole valid DEM, 460x317 cells
      of 30 m, 153x106 at 90 m) centred at **(640, 870)**, rotation 0,
      scale **1.35** (a footprint of about 207x143 cells, 19 x 13 km),
      inside the volcanic region (Mount Doom);
    * ``pins`` (row, col, metres): a summit of the high range at
      **(215, 585) = 4000 m** (Caradhras; about the Himalayan example's
      97th percentile), a hill in the northern upland at **(130, 330) =
      900 m** (Weathertop) and a low hill in the shire at **(380, 300) =
      250 m**.

The same run from the command line (or ``terrasynth-cli demo --map
middle-earth``, which reads the JSON)::

    terrasynth-cli synth --sketch resources/sketches/middle_earth_sketch.png --out out.tif \\
        --styles resources/sketches/middle_earth_styles.png \\
        --style "#8a6a55=builtin:himalaya" --style "#8fbf5f=builtin:white-mountains" \\
        --style "#e6d98c=builtin:gabon-plateau" --style "#3c2323=builtin:big-tujunga" \\
        --water resources/sketches/middle_earth_water.png --water-level 60 \\
        --stamp builtin:st-helens@640,870,0,1.35 --cell-size 90 \\
        --pin 215,585,4000 --pin 130,330,900 --pin 380,300,250

:func:`load_demo` reads them through the core's ``middle-earth`` preset
(:func:`terrasynth_core.presets.load_preset`), at the map's size or scaled.

Regions are thresholded distance fields (to smooth spines and centres)
perturbed by smoothed noise, so their borders are organic curves.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw
from scipy import ndimage

from terrasynth_core.features import SketchMap, resize_nearest
from terrasynth_core.exemplars.patch_size import DEFAULT_PATCH
from terrasynth_core.presets import load_preset
from terrasynth_core.synthesis import Controls, SynthesisParams

REPO = Path(__file__).resolve().parents[1]
SHAPE = (768, 1024)
SEED = 3019

#: Style label -> (name, flat colour, DEM).  Label order is the style order.
STYLES = (
    ("high mountains", "#8a6a55", "builtin:himalaya"),
    ("rolling hills", "#8fbf5f", "builtin:white-mountains"),
    ("lowland plateau", "#e6d98c", "builtin:gabon-plateau"),
    ("volcanic land", "#3c2323", "builtin:big-tujunga"),
)
MOUNTAINS, HILLS, LOWLAND, VOLCANIC = range(4)
WATER_LEVEL = 60.0
STAMP = {"dem": "builtin:st-helens", "center": [640, 870], "rotation": 0.0, "scale": 1.35}
#: The map was designed at about 90 m cells (the Himalayan example's); left
#: automatic, Big Tujunga's 30 m would make the whole map three times smaller.
CELL_SIZE = 90
PINS = (
    {"name": "summit of the high range", "row": 215, "col": 585, "height": 4000.0},
    {"name": "hill in the northern upland", "row": 130, "col": 330, "height": 900.0},
    {"name": "low hill in the shire", "row": 380, "col": 300, "height": 250.0},
)
STROKE = 4

# Spines as (row, col) control points; smoothed into curves.
RANGE_SPINE = ((15, 600), (110, 585), (215, 585), (330, 600), (440, 585), (520, 560))
SOUTH_ARM = ((520, 560), (565, 500), (590, 420), (600, 330))
RIVER = ((345, 508), (372, 470), (392, 420), (430, 385), (452, 330), (468, 270), (500, 215), (525, 160),
         (540, 90))
EAST_VALLEY = ((40, 760), (150, 745), (260, 760), (360, 740), (440, 705))
WEST_VALLEYS = (((150, 525), (175, 470), (210, 430)), ((270, 530), (300, 470), (320, 430)))
SPURS = (((110, 585), (80, 645), (60, 690)), ((330, 600), (360, 655), (400, 680)),
         ((215, 585), (240, 530)))
UPLAND_RIDGE = ((95, 250), (120, 300), (130, 330), (150, 390))
VOLCANIC_RIDGES = (((520, 745), (590, 738), (670, 745), (745, 760)),   # the western fence (Ephel Duath)
                   ((505, 770), (500, 850), (505, 940), (520, 1010)))  # the northern fence (Ered Lithui)


# -- geometry -------------------------------------------------------------------
def smooth_curve(points, *, step: float = 1.0, rounds: int = 4) -> np.ndarray:
    """Chaikin corner cutting of a polyline, resampled every ``step`` cells.

    Returns
    -------
    ndarray of float, shape (n, 2)
        (row, col) points; the ends stay where they were.
    """
    p = np.asarray(points, dtype=np.float64)
    for _ in range(rounds):
        q = 0.75 * p[:-1] + 0.25 * p[1:]
        r = 0.25 * p[:-1] + 0.75 * p[1:]
        p = np.vstack([p[:1], np.column_stack([q, r]).reshape(-1, 2), p[-1:]])
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    t = np.arange(0.0, s[-1] + step, step)
    return np.column_stack([np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])])


def meander(curve: np.ndarray, *, amplitude: float, wavelength: float) -> np.ndarray:
    """``curve`` displaced sideways by a sine of its arc length (a river's
    bends), zero at both ends."""
    d = np.gradient(curve, axis=0)
    d /= np.hypot(d[:, 0], d[:, 1])[:, None]
    normal = np.column_stack([-d[:, 1], d[:, 0]])
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(curve, axis=0).T))]
    offset = amplitude * np.sin(2 * np.pi * s / wavelength) * np.sin(np.pi * s / s[-1])
    return curve + offset[:, None] * normal


def curve_distance(curve: np.ndarray, shape) -> tuple[np.ndarray, np.ndarray]:
    """Distance (cells) from every cell to ``curve``, and the arc-length
    fraction (0..1) of the nearest curve point."""
    line = np.zeros(shape, bool)
    frac = np.zeros(shape)
    rc = np.round(curve).astype(int)
    inside = (rc[:, 0] >= 0) & (rc[:, 0] < shape[0]) & (rc[:, 1] >= 0) & (rc[:, 1] < shape[1])
    line[rc[inside, 0], rc[inside, 1]] = True
    frac[rc[inside, 0], rc[inside, 1]] = np.linspace(0.0, 1.0, len(curve))[inside]
    dist, (ir, ic) = ndimage.distance_transform_edt(~line, return_indices=True)
    return dist, frac[ir, ic]


def noise(shape, sigma: float, rng: np.random.Generator) -> np.ndarray:
    """Smoothed white noise scaled to unit standard deviation."""
    n = ndimage.gaussian_filter(rng.standard_normal(shape), sigma, mode="wrap")
    return n / n.std()


def largest_component(mask: np.ndarray) -> np.ndarray:
    """The largest 4-connected part of ``mask``."""
    labels, n = ndimage.label(mask)
    if n <= 1:
        return mask
    sizes = ndimage.sum(mask, labels, index=np.arange(1, n + 1))
    return labels == 1 + int(np.argmax(sizes))


# -- the maps -------------------------------------------------------------------
def draw_maps(seed: int = SEED) -> dict:
    """Style labels, water mask and stroke masks of the demo, ``SHAPE``
    (the geometry above is in its cells).

    Returns
    -------
    dict
        ``labels`` (int16, rows x cols, 0..3 in ``STYLES`` order),
        ``water`` (bool), ``ridges`` and ``valleys`` (bool stroke masks).
    """
    rng = np.random.default_rng(seed)
    shape = rows, cols = SHAPE
    rr, cc = np.mgrid[0:rows, 0:cols].astype(np.float64)
    wobble = noise(shape, 18.0, rng)
    fine = noise(shape, 7.0, rng)
    broad = noise(shape, 40.0, rng)

    # The sea: a wavy western coast with a gulf cutting east into the land.
    coast = 150 + 45 * np.sin(rr / 97.0) + 25 * np.sin(rr / 41.0 + 1.0)
    gulf = 130 * np.exp(-((rr - 230) / 38.0) ** 2) * (cc < 330)
    sea = cc + 18 * wobble + 6 * fine < coast + gulf
    # One sea touching the western edge, no islands in it, no ponds inland.
    sea = ~largest_component(~largest_component(sea | (cc < 20)))

    range_curve = smooth_curve(RANGE_SPINE)
    arm_curve = smooth_curve(SOUTH_ARM)
    d_range, f_range = curve_distance(range_curve, shape)
    d_arm, _ = curve_distance(arm_curve, shape)
    # The range narrows towards its northern tip; the arm is narrower.
    half_width = np.minimum(62.0, 30.0 + 200.0 * f_range)
    mountains = ((d_range < half_width + 10 * wobble + 4 * fine)
                 | (d_arm < 48 + 8 * wobble + 4 * fine))
    d_mountains = ndimage.distance_transform_edt(~mountains)

    upland = np.hypot((rr - 120) / 85.0, (cc - 320) / 120.0) < 1.0 + 0.15 * broad + 0.05 * wobble
    east = (cc > 770 + 40 * broad) & (rr < 420 + 40 * broad)
    hills = (d_mountains < 70 + 30 * broad + 5 * wobble) | upland | east

    volcanic = np.hypot((rr - 630) / 165.0, (cc - 875) / 180.0) < 1.0 + 0.08 * broad + 0.05 * wobble

    labels = np.full(shape, LOWLAND, np.int16)
    labels[hills] = HILLS
    labels[mountains] = MOUNTAINS
    labels[volcanic] = VOLCANIC
    labels[sea] = LOWLAND
    labels = _absorb_specks(labels, min_cells=4000)

    # One lake in the lowland, and the river from the range's foot to the sea.
    lake = np.hypot((rr - 290) / 30.0, (cc - 335) / 52.0) < 1.0 + 0.18 * fine
    river_curve = meander(smooth_curve(RIVER, step=0.5), amplitude=9.0, wavelength=70.0)
    d_river, f_river = curve_distance(river_curve, shape)
    river = d_river < 1.5 + 2.0 * f_river
    water = sea | lake | river

    ridges = _strokes(shape, [RANGE_SPINE, SOUTH_ARM, UPLAND_RIDGE, *SPURS, *VOLCANIC_RIDGES])
    # The river's valley stroke stops at the coast.
    ri = np.clip(np.round(river_curve).astype(int), 0, [rows - 1, cols - 1])
    valleys = _strokes(shape, [EAST_VALLEY, *WEST_VALLEYS], extra=[river_curve[~sea[ri[:, 0], ri[:, 1]]]])
    ridges &= ~valleys
    return {"labels": labels, "water": water, "ridges": ridges, "valleys": valleys}


def _absorb_specks(labels: np.ndarray, *, min_cells: int) -> np.ndarray:
    """Every connected part smaller than ``min_cells`` takes the label most
    common just around it, so regions are few and large."""
    out = labels.copy()
    for label in np.unique(labels):
        parts, n = ndimage.label(labels == label)
        sizes = np.bincount(parts.ravel(), minlength=n + 1)
        for i in np.flatnonzero(sizes[1:] < min_cells) + 1:
            part = parts == i
            ring = ndimage.binary_dilation(part, iterations=2) & ~part
            out[part] = np.bincount(out[ring]).argmax()
    return out


def _strokes(shape, polylines, *, extra=()) -> np.ndarray:
    """``STROKE``-pixel lines along smoothed ``polylines`` and along the
    ready-made curves in ``extra`` (drawn without anti-aliasing)."""
    img = Image.new("1", (shape[1], shape[0]), 0)
    draw = ImageDraw.Draw(img)
    for curve in [smooth_curve(p) for p in polylines] + list(extra):
        xy = [(float(c), float(r)) for r, c in curve[::2]]
        draw.line(xy, fill=1, width=STROKE, joint="curve")
    return np.array(img, dtype=bool)


def write_maps(out: Path, maps: dict) -> list[Path]:
    """Save the three PNGs and the JSON in ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    palette = np.array([[int(c[i:i + 2], 16) for i in (1, 3, 5)] for _, c, _ in STYLES], np.uint8)
    paths = [out / "middle_earth_styles.png", out / "middle_earth_water.png", out / "middle_earth_sketch.png",
             out / "middle_earth.json"]
    Image.fromarray(palette[maps["labels"]]).save(paths[0], optimize=True)
    Image.fromarray(np.where(maps["water"], 0, 255).astype(np.uint8)).save(paths[1], optimize=True)
    sketch = np.full(maps["labels"].shape + (3,), 255, np.uint8)
    sketch[maps["ridges"]] = (255, 0, 0)
    sketch[maps["valleys"]] = (0, 0, 255)
    Image.fromarray(sketch).save(paths[2], optimize=True)
    spec = {
        "shape": list(maps["labels"].shape),
        "cell_size": CELL_SIZE,
        "style_map": paths[0].name,
        "styles": {colour: dem for _, colour, dem in STYLES},
        "style_names": {colour: name for name, colour, _ in STYLES},
        "sketch": paths[2].name,
        "water": {"mask": paths[1].name, "level": WATER_LEVEL},
        "stamp": STAMP,
        "pins": list(PINS),
    }
    paths[3].write_text(json.dumps(spec, indent=2) + "\n")
    return paths


# -- reading the demo ----------------------------------------------------------------
def load_demo(*, shape=None) -> tuple[SketchMap, Controls, float]:
    """The demo as the core's ``middle-earth`` preset reads it, optionally
    scaled to another size.

    Parameters
    ----------
    shape : (rows, cols), optional
        Output size; default the map's own (768x1024).  Maps are resized by
        nearest neighbour; the stamp's centre and the pins scale with the
        rows (the stamp keeps its ground size: the cell size of
        :func:`demo_params` grows as the map shrinks).

    Returns
    -------
    sketch : SketchMap
        At ``shape``.
    controls : Controls
        Styles in ``STYLES`` order (label i = style i), water, the stamp and
        the pins.
    scale : float
        Output rows / map rows.
    """
    preset = load_preset("middle-earth")
    c = preset.controls
    shape = preset.shape if shape is None else tuple(int(v) for v in shape)
    f = shape[0] / preset.shape[0]
    if shape == tuple(preset.shape):
        return preset.sketch, c, 1.0
    stamps = tuple(replace(st, center=(st.center[0] * f, st.center[1] * f)) for st in c.stamps)
    pins = tuple(replace(p, row=min(round(p.row * f), shape[0] - 1), col=min(round(p.col * f), shape[1] - 1))
                 for p in c.pins)
    water = replace(c.water, mask=resize_nearest(c.water.mask, shape))
    controls = replace(c, style_map=resize_nearest(c.style_map, shape), water=water, stamps=stamps, pins=pins)
    return preset.sketch.resized(shape), controls, f


def demo_params(*, seed: int, scale: float) -> SynthesisParams:
    """Parameters of the demo at ``scale`` (output rows / map rows): the same
    ground at any size, so the cell size grows as the map shrinks.  At the
    map's own size the patch size is automatic (48 cells there); at any
    other it is the paper's 80 scaled with the map (at least 32), the
    ground 80 cells span at the map's size."""
    preset = load_preset("middle-earth")
    patch = None if scale == 1 else max(32, round(DEFAULT_PATCH * scale))
    return SynthesisParams(seed=seed, patch_size=patch,
                           cell_size=None if preset.cell_size is None else preset.cell_size / scale)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "resources" / "sketches", help="output folder")
    args = parser.parse_args(argv)
    maps = draw_maps()
    for path in write_maps(args.out, maps):
        print(f"wrote {path}")
    labels, water = maps["labels"], maps["water"]
    for i, (name, colour, dem) in enumerate(STYLES):
        print(f"  {name:<16} {colour} {dem:<26} {100 * (labels == i).mean():5.1f} % of the map, "
              f"{100 * (water & (labels == i)).mean():4.1f} % water")
    return 0


if __name__ == "__main__":
    sys.exit(main())
