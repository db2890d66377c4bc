"""The artist controls in a tiled run: style regions, water, stamps and
pins, given once for the whole map, and what each tile takes of them.

The style map and the water mask are painted at any resolution and scaled
to the output; a tile takes only its window of the scaled map, computed
from the painted pixels under it (nearest, as a whole-map run scales them),
so no process holds a map at the output's size.  Pins and stamps are in
output cells: a tile gets the pins in its crop and the stamps whose
footprint lies in it.

The level field is the whole map's: each tile computes its window of it
over its crop and a margin wide enough that the window's edge leaves no
trace inside the crop (the regions' bases blurred across their borders,
then bent through the pins within reach), so neighbouring tiles agree.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..controls.levels import LEVEL_SIGMA, PIN_LEVEL_REACH, level_field, steer_level
from ..controls.options import Controls, Stamp, Style, check_heights
from ..controls.pins import Pin
from ..controls.stamps import render_stamp
from ..controls.water import Water, check_bank_width
from ..errors import ParamsError
from ..heightfield import HeightField
from .plan import TilePlan

__all__ = ["MapControls", "TileControls", "map_controls"]

Box = tuple[int, int, int, int]

#: Share of the examples' height span a water bed lies below the level when
#: no depth is given (a whole-map run takes 3 % of its finished terrain's
#: span, which a tiled run does not know before its tiles are made).
DEPTH_SHARE = 0.03


@dataclass(frozen=True)
class MapControls:
    """A tiled run's controls, checked once on the coordinator.

    Parameters
    ----------
    n_plain : int
        The run's plain examples; the examples sent to the workers are
        these, then one per style, then one per stamp.
    styles : tuple of (relief_scale, base, name)
        Each style, without its example (sent once with the others).
    style_map : ndarray of int16 or None
        As painted (any size with the output's aspect ratio); -1 is the
        plain examples.
    water : Water or None
        Its mask as painted; ``depth`` given (see :data:`DEPTH_SHARE`).
    stamps : tuple of Stamp
        Output cells; ``field`` None (sent with the examples).
    stamp_tiles : tuple of (row, col)
        The tile that places each stamp.
    pins : tuple of Pin
        Output cells.
    pin_radius : float
        Cells.
    bases : ndarray of float, shape (groups,)
        Each style group's base height (the plain examples first), metres.
    """

    n_plain: int
    styles: tuple
    style_map: np.ndarray | None
    water: Water | None
    stamps: tuple
    stamp_tiles: tuple
    pins: tuple
    pin_radius: float
    bases: np.ndarray

    def description(self) -> dict:
        """What a tile's heights depend on, for the run's digest."""
        h = hashlib.sha256()
        for arr in (self.style_map, None if self.water is None else self.water.mask):
            if arr is not None:
                h.update(np.ascontiguousarray(arr).data)
                h.update(repr(arr.shape).encode())
        return {"styles": [list(map(repr, s)) for s in self.styles], "maps": h.hexdigest(),
                "water": None if self.water is None else [self.water.level, self.water.depth, self.water.bank_width],
                "stamps": [[list(s.center), s.rotation, s.scale, None if s.window is None else list(s.window)]
                           for s in self.stamps],
                "pins": [[p.row, p.col, p.height] for p in self.pins], "pin_radius": self.pin_radius,
                "bases": [float(b) for b in self.bases]}

    def for_tile(self, tile, shape: tuple[int, int], patch_size: int) -> "TileControls":
        """What ``tile`` (of an output of ``shape``) takes of the controls."""
        r0, r1, c0, c1 = tile.crop
        ext = _level_box(tile.crop, shape, patch_size)
        e0, e1, f0, f1 = ext
        groups = None
        if self.style_map is not None:
            groups = (window_nearest(self.style_map, shape, ext) + (1 if self.n_plain else 0)).astype(np.int16)
        style_map = None if self.style_map is None else window_nearest(self.style_map, shape, tile.crop)
        water = None
        if self.water is not None:
            mask = window_nearest(self.water.mask, shape, tile.crop).astype(bool)
            if mask.any():
                water = dataclasses.replace(self.water, mask=mask)
        stamps = tuple((self.n_plain + len(self.styles) + i, (s.center[0] - r0, s.center[1] - c0), s.rotation,
                        s.scale, s.window)
                       for i, (s, key) in enumerate(zip(self.stamps, self.stamp_tiles)) if key == tile.key)
        pins = tuple(Pin(p.row - r0, p.col - c0, p.height) for p in self.pins if r0 <= p.row < r1 and c0 <= p.col < c1)
        steering = tuple(Pin(p.row - e0, p.col - f0, p.height) for p in self.pins
                         if e0 <= p.row < e1 and f0 <= p.col < f1)
        return TileControls(self.n_plain, self.styles, style_map, water, stamps, pins, self.pin_radius,
                            ext, groups, self.bases, steering)


@dataclass(frozen=True)
class TileControls:
    """A tile's part of :class:`MapControls` (crop cells unless said).

    Parameters
    ----------
    n_plain, styles, pin_radius, bases
        As :class:`MapControls`.
    style_map : ndarray of int16 or None
        Over the crop.
    water : Water or None
        Its mask over the crop (None when the crop has no water).
    stamps : tuple of (example index, centre, rotation, scale, window)
        The stamps this tile places.
    pins : tuple of Pin
        Those in the crop.
    level_box : (r0, r1, c0, c1)
        Output cells the tile computes its level over: the crop and a
        margin (:func:`_level_box`).
    groups : ndarray of int16 or None
        The style groups over ``level_box`` (None: all plain).
    steering : tuple of Pin
        The pins in ``level_box``, in its cells.
    """

    n_plain: int
    styles: tuple
    style_map: np.ndarray | None
    water: Water | None
    stamps: tuple
    pins: tuple
    pin_radius: float
    level_box: Box
    groups: np.ndarray | None
    bases: np.ndarray
    steering: tuple

    def controls(self, examples: Sequence[HeightField], *, previous=None, selection=None) -> Controls:
        """The tile session's :class:`Controls` (``examples``: the run's, as sent)."""
        styles = tuple(Style(examples[self.n_plain + i], relief, base, name)
                       for i, (relief, base, name) in enumerate(self.styles))
        stamps = tuple(Stamp(examples[i], center, rotation, scale, window)
                       for i, center, rotation, scale, window in self.stamps)
        return Controls(styles=styles, style_map=self.style_map, water=self.water, stamps=stamps, pins=self.pins,
                        pin_radius=self.pin_radius, previous=previous, selection=selection)

    def plain_level(self, patch_size: int) -> np.ndarray:
        """The whole map's level over :attr:`level_box` without a landform
        pass: the groups' bases blurred across their borders
        (:func:`~terrasynth_core.controls.levels.level_field`)."""
        r0, r1, c0, c1 = self.level_box
        groups = np.zeros((r1 - r0, c1 - c0), np.int16) if self.groups is None else self.groups
        return level_field(groups, self.bases, patch_size)

    def steered(self, level: np.ndarray, patch_size: int) -> np.ndarray:
        """``level`` (over :attr:`level_box`) bent through the pins, as the
        whole map's (:func:`~terrasynth_core.controls.levels.steer_level`)."""
        return steer_level(level, self.steering, patch_size)


def _level_box(crop: Box, shape: tuple[int, int], patch_size: int) -> Box:
    """The crop and the margin within which the whole map's level is made
    the same: the blur across region borders (4 sigmas) and the pins' pull
    and its solve (:data:`~terrasynth_core.controls.levels.PIN_LEVEL_REACH`
    patches, twice: a pin that far outside bends the level inside), aligned
    on the steering's coarse grid (every ``patch_size // 16`` cells, from
    the map's corner) so the window samples the same coarse cells."""
    margin = int(math.ceil(max(4 * LEVEL_SIGMA, 2 * PIN_LEVEL_REACH) * patch_size)) + 1
    f = max(1, patch_size // 16)
    r0, r1, c0, c1 = crop
    rows, cols = shape
    a0, b0 = max(r0 - margin, 0) // f * f, max(c0 - margin, 0) // f * f
    return a0, min(r1 + margin, rows), b0, min(c1 + margin, cols)


def window_nearest(painted: np.ndarray, shape: tuple[int, int], box: Box) -> np.ndarray:
    """The window ``box`` (output cells) of ``painted`` scaled to ``shape``
    by nearest cell, as :func:`~terrasynth_core.features.sketch.resize_nearest`
    scales the whole map (each cell takes the painted pixel under its centre)."""
    r0, r1, c0, c1 = box
    rows = painted_index(np.arange(r0, r1), painted.shape[0], shape[0])
    cols = painted_index(np.arange(c0, c1), painted.shape[1], shape[1])
    return painted[np.ix_(rows, cols)]


def painted_index(cells: np.ndarray, painted: int, size: int) -> np.ndarray:
    """The painted pixel under each output cell's centre, along one axis of
    ``size`` output cells and ``painted`` pixels."""
    return np.minimum(((np.asarray(cells) + 0.5) * painted / size).astype(int), painted - 1)


def _same_aspect(name: str, arr: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """``arr`` as a 2-D map; refused when its aspect ratio is not the output's."""
    arr = np.asarray(arr)
    if arr.ndim != 2:
        raise ParamsError(f"{name} must be a 2-D array, got shape {arr.shape}")
    if abs((arr.shape[0] / arr.shape[1]) / (shape[0] / shape[1]) - 1) > 0.02:
        raise ParamsError(f"{name} is {arr.shape[0]}x{arr.shape[1]} but the output is {shape[0]}x{shape[1]} "
                          "(another aspect ratio): paint it with the output's proportions")
    return arr


def map_controls(controls: Controls | None, examples: Sequence, shape: tuple[int, int], plan: TilePlan,
                 params, layout) -> MapControls:
    """Check a tiled run's controls once and put them in the form tiles take.

    Parameters
    ----------
    controls : Controls or None
        Maps as painted (any size with the output's aspect ratio), pins and
        stamps in output cells.  No height range or re-synthesis.
    examples : sequence of HeightField or ndarray
        The plain examples.
    shape : (rows, cols)
        The output.
    plan : TilePlan
    params : SynthesisParams
    layout : StyleLayout
        Of a small session with the same examples and styles (their
        analysis at the run's cell size).

    Raises
    ------
    ParamsError
        Naming the bad control.
    """
    controls = Controls() if controls is None else controls
    if controls.height_range is not None:
        raise ParamsError("a height range needs the whole terrain's span (it maps the lowest and highest cell): "
                          "render without --tile, or map the GeoTIFF's heights afterwards")
    if controls.selection is not None or controls.previous is not None:
        raise ParamsError("a tiled run makes a new terrain: a re-synthesis runs without tiles")
    n_plain = len(examples)
    style_map = None
    if controls.styles:
        painted = controls.style_map
        if painted is None:
            painted = np.zeros((1, 1), np.int16)  # one style everywhere
        painted = _same_aspect("style map", painted, shape)
        # The styles and labels checked as a whole-map run checks them (at the painted size).
        Controls(styles=controls.styles, style_map=painted).checked(painted.shape, n_plain)
        style_map = painted.astype(np.int16)
    elif controls.style_map is not None:
        raise ParamsError("a style map needs styles: give one Style per colour")
    # Pins and stamps checked on the output's grid (no map at its size is
    # made; the styles were checked above), then the pins against the heights.
    checked = Controls(stamps=controls.stamps, pins=controls.pins, pin_radius=controls.pin_radius).checked(
        shape, max(n_plain, 1))
    check_heights(examples, Controls(styles=controls.styles, stamps=checked.stamps, pins=checked.pins))
    bases = group_bases(layout, controls.styles, n_plain)
    water = None
    if controls.water is not None:
        mask = _same_aspect("water mask", controls.water.mask, shape)
        water = Water(mask, controls.water.level, controls.water.depth, controls.water.bank_width).checked(mask.shape)
        check_bank_width(water.bank_width, shape)  # (the output's size, not the painted mask's)
        if water.depth is None:
            water = dataclasses.replace(water, depth=DEPTH_SHARE * _height_span(layout, bases))
    stamp_tiles = tuple(_stamp_tile(i, st, shape, plan, params.patch_size, layout.cell_size)
                        for i, st in enumerate(checked.stamps))
    stamps = tuple(dataclasses.replace(st, field=None) for st in checked.stamps)
    return MapControls(n_plain, tuple((float(s.relief_scale), s.base, s.name) for s in controls.styles), style_map,
                       water, stamps, stamp_tiles, checked.pins, checked.pin_reach(params.patch_size), bases)


def group_bases(layout, styles: Sequence[Style], n_plain: int) -> np.ndarray:
    """Each style group's base height, metres, as a whole-map run's layout
    sets them (:func:`~terrasynth_core.controls.layout.build_layout`): the
    plain examples' mean median first, then each style's base or its
    example's median."""
    medians = [float(np.median(ex.valid_values(ex.heights))) for ex in layout.examples]
    given = ([None] if n_plain else []) + [s.base for s in styles]
    return np.array([float(np.mean([medians[i] for i in members])) if b is None else float(b)
                     for members, b in zip(layout.members, given)])


def _height_span(layout, bases: np.ndarray) -> float:
    """The examples' height span about their bases (their relief scales
    applied), metres: what a water bed's default depth is a share of."""
    spans = [float(np.ptp(d)) for d in layout.detail]
    return (max(spans) if spans else 0.0) + float(np.ptp(bases))


def _stamp_tile(i: int, stamp: Stamp, shape, plan: TilePlan, patch_size: int, cell_size) -> tuple[int, int]:
    """The tile that places stamp ``i``: the one tile whose region holds
    its whole footprint (no other tile makes any of its cells)."""
    r0, r1, c0, c1 = render_stamp(stamp, tuple(shape), patch_size, cell_size=cell_size, notes=[]).bbox
    makers = [t for t in plan.tiles
              if t.region[0] < r1 and r0 < t.region[1] and t.region[2] < c1 and c0 < t.region[3]]
    inside = [t for t in makers if t.crop[0] <= r0 and r1 <= t.crop[1] and t.crop[2] <= c0 and c1 <= t.crop[3]]
    if len(makers) != 1 or not inside:
        raise ParamsError(f"stamp {i + 1} covers rows {r0}..{r1}, columns {c0}..{c1}, across the border of tiles of "
                          f"{plan.tile} cells: a tiled run places each stamp inside one tile (half a patch from its "
                          "edges); move the stamp or use larger tiles")
    return inside[0].key
