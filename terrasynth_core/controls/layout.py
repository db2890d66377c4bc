"""Which examples serve which output cells, at what level and scale.

A run has style *groups*: the session's plain examples (one group, used for
unpainted cells) and one group per :class:`~.controls.Style`.  Every example
is synthesized as detail about its median height, times its style's relief
scale; the level field (:func:`.levels.level_field`) adds each region's
base height back, smoothly across region borders.

Every example, style and stamp is first brought to the run's square cell
size (:mod:`~terrasynth_core.exemplars.ground`), so all of them are copied
at their true scale on the ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..exemplars import cache
from ..exemplars.ground import on_ground, run_cell_size
from ..exemplars.mapped_pages import checked
from ..exemplars.patch_size import fitting_patch_size
from ..exemplars.prepare import ExampleAnalysis, prepare_example
from ..matching.costs import anchor_weight, level_spread
from ..memo import Memo, array_key
from .levels import level_field, steer_level
from .options import Controls
from .stamps import RenderedStamp, render_stamp


@dataclass(frozen=True, eq=False)
class StyleLayout:
    """Examples, groups and the level field of one run.

    Parameters
    ----------
    examples : list of ExampleAnalysis
        Plain examples first, then one per style.
    detail : list of ndarray of float32, shape (H_i, W_i)
        Each example's heights minus its median, times its relief scale
        (and the height-range factor).
    relief : ndarray of float, shape (n_examples,)
        Each example's relief after the same scaling, metres.
    members : list of list of int
        Example indices per group.
    names : list of str
        Group names for messages.
    group_map : ndarray of int16, shape (rows, cols)
        Group per output cell.
    level : ndarray of float32, shape (rows, cols)
        Large-scale elevation the detail sits on, metres.
    stamps : list of RenderedStamp
        With detail scaled like the examples'.
    remap : (lo, hi, a, b) or None
        Height range: the styles were scaled by ``a`` (``x -> a x + b`` on
        predicted heights) towards ``(lo, hi)``; the result is mapped onto
        it exactly at the end.
    notes : list of str
        Nodata handling, cell size and up-sampling, for the run's warnings.
    cell_size : float or None
        The run's square cell size in metres (None: unknown, examples used
        cell for cell).
    anchor : ndarray of float, shape (n_examples,)
        Each example's shift weight in match costs
        (:func:`~terrasynth_core.matching.costs.anchor_weight`).
    heights : ndarray of float, shape (n_groups, 2)
        The lowest and highest heights each group's examples have as placed
        (its base height plus their heights about their medians, scaled),
        metres: what :meth:`height_range` reads, since ``detail`` becomes
        the band above the landform split during a run.
    """

    examples: list
    detail: list
    relief: np.ndarray
    members: list
    names: list
    group_map: np.ndarray
    level: np.ndarray
    stamps: list
    remap: tuple | None
    notes: list
    cell_size: float | None
    anchor: np.ndarray
    heights: np.ndarray

    def height_range(self) -> tuple[float, float]:
        """The lowest and highest heights of the examples of the groups
        the output uses, as placed, metres."""
        used = np.unique(self.group_map)
        return float(self.heights[used, 0].min()), float(self.heights[used, 1].max())

    def group_at(self, row: float, col: float) -> int:
        rows, cols = self.group_map.shape
        return int(self.group_map[min(max(int(round(row)), 0), rows - 1), min(max(int(round(col)), 0), cols - 1)])


def build_layout(plain: list, controls: Controls, shape: tuple[int, int], patch_size: int, *,
                 cell_size: float | None = None, grounded: "Grounded | None" = None) -> StyleLayout:
    """Bring the examples to one cell size, analyse them and lay the styles
    out over the output.

    Parameters
    ----------
    plain : list of HeightField or ndarray
        The session's examples (the default style).
    controls : Controls
        Already checked against ``shape``.
    shape : (rows, cols)
    patch_size : int
    cell_size : float or None
        Metres per output cell; None: the finest example's
        (:func:`~terrasynth_core.exemplars.ground.run_cell_size`).
    grounded : Grounded, optional
        :func:`grounded_examples` of the same examples, controls and cell
        size, when the caller has it already.
    """
    # Examples in the grounded order: the plain ones, then each style's.
    scales, bases, members, names = [], [], [], []
    if plain:
        members.append(list(range(len(plain))))
        names.append("default examples")
        scales.extend([1.0] * len(plain))
        bases.append(None)
    for i, style in enumerate(controls.styles):
        members.append([len(plain) + i])
        names.append(style.name or f"style {i + 1}")
        scales.append(float(style.relief_scale))
        bases.append(style.base)
    examples: list[ExampleAnalysis] = []
    notes = []
    grounded = grounded or grounded_examples(plain, controls, cell_size)
    cell = grounded.cell
    if cell is None:
        notes.append("no example has a known cell size: examples are used cell for cell and the output's "
                     "cell size is unknown")
    # Each example's median, lowest and highest cell (its filled voids left out).
    spans = np.empty((len(grounded.fields), 3))
    # (Each example is read whole here and below, once a pass: checked()
    # hands a large library's pages back as it goes, mapped_pages.)
    for i, (ex, name, said) in enumerate(checked(zip(grounded.fields, grounded.names, grounded.notes))):
        notes.extend(said)
        analysis = prepare_example(ex, patch_size, name=name)
        if analysis.note:
            notes.append(analysis.note)
        examples.append(analysis)
        real = analysis.valid_values(analysis.heights)
        spans[i] = np.median(real), real.min(), real.max()
    medians = spans[:, 0]
    scales = np.array(scales)
    base = np.array([float(np.mean(medians[m])) if b is None else float(b) for m, b in zip(members, bases)])

    if controls.style_map is None:
        group_map = np.zeros(shape, np.int16)
    else:
        # Label -1 is the plain examples' group (0 when there are any).
        offset = 1 if plain else 0
        group_map = (controls.style_map.astype(np.int16) + offset).astype(np.int16)
        if not plain:
            group_map = np.maximum(group_map, 0).astype(np.int16)

    factor, remap = 1.0, None
    if controls.height_range is not None:
        lo, hi = controls.height_range
        used = np.unique(group_map)
        low = min(base[g] + scales[i] * (spans[i, 1] - medians[i]) for g in used for i in members[g])
        high = max(base[g] + scales[i] * (spans[i, 2] - medians[i]) for g in used for i in members[g])
        factor = (hi - lo) / max(high - low, 1e-6)
        shift = lo - factor * low
        base = factor * base + shift
        remap = (lo, hi, factor, shift)
    detail, detail_span = [], np.empty((len(examples), 2))
    for i, (ex, med, s) in enumerate(checked(zip(examples, medians, scales))):
        detail.append(_detail(ex.heights, med, s * factor))
        detail_span[i] = detail[-1].min(), detail[-1].max()
    relief = np.array([ex.relief for ex in examples]) * scales * factor
    level = level_field(group_map, base, patch_size)
    if controls.selection is None:
        # (A re-synthesis keeps the pins' surroundings it does not select.)
        level = steer_level(level, controls.pins, patch_size)
    stamps = []
    for st in controls.stamps:
        r = render_stamp(st, shape, patch_size, cell_size=cell, notes=notes)
        stamps.append(RenderedStamp(r.bbox, (r.detail * np.float32(factor)).astype(np.float32), r.valid, r.core))
    placed = np.array([[base[g] + detail_span[m, 0].min(), base[g] + detail_span[m, 1].max()]
                       for g, m in enumerate(members)])
    return StyleLayout(examples, detail, relief, members, names, group_map, level, stamps, remap, notes, cell,
                       anchors(detail, relief, patch_size, [ex.valid for ex in examples]), placed)


@dataclass(frozen=True, eq=False)
class Grounded:
    """A run's examples (plain, then each style's) at its square cell size.

    Parameters
    ----------
    fields : list of HeightField or ndarray
    names : list of str
        For messages.
    cell : float or None
        The run's cell size, metres.
    notes : list of list of str
        Each example's notes from :func:`~terrasynth_core.exemplars.ground.on_ground`.
    """

    fields: list
    names: list
    cell: float | None
    notes: list


def grounded_examples(plain: list, controls: Controls, cell_size: float | None = None) -> Grounded:
    """The run's examples brought to its cell size (the finest example's,
    stamps included, or ``cell_size``); ``controls`` need only hold Styles
    and Stamps (:meth:`~.options.Controls.check_kinds`)."""
    fields = [*plain, *(st.example for st in controls.styles)]
    cell = run_cell_size(cell_size, [*fields, *(st.field for st in controls.stamps)])
    names = [_example_name(ex, i) for i, ex in enumerate(fields)]
    both = [on_ground(ex, cell, name=name) for ex, name in checked(zip(fields, names))]
    return Grounded([g for g, _ in both], names, cell, [said for _, said in both])


def automatic_patch_size(grounded: Grounded, kinds: tuple[str, ...], *,
                         largest: int | None = None) -> tuple[int, list[str]]:
    """The patch size the run's examples can serve, for a sketch drawing
    ``kinds``, at most ``largest``
    (:func:`~terrasynth_core.exemplars.patch_size.fitting_patch_size`), and
    its notes for the warnings.  Kept by the examples' bytes: every run and
    variation of a document asks again."""
    key = (tuple(array_key(np.asarray(getattr(g, "heights", g))) for g in checked(grounded.fields)),
           tuple(grounded.names), tuple(kinds), largest)
    size, notes = _PATCH_SIZES.get(
        key, lambda: fitting_patch_size(grounded.fields, grounded.names, kinds, largest=largest))
    return size, list(notes)


def _example_name(ex, i: int) -> str:
    """An example's name in messages: its source, or its place in the run."""
    return str(getattr(ex, "source", None) or f"example {i + 1}")


#: The automatic patch size by the examples' bytes and the kinds drawn.
_PATCH_SIZES = Memo(16)

#: Examples' detail heights by what they are made of (:func:`_detail`).
_DETAILS = Memo(8)


def _detail(heights: np.ndarray, median: float, scale: float) -> np.ndarray:
    """An example's detail, ``(heights - median) * scale``, metres.

    Made once per example and scale and kept: in memory for the next
    sessions (the app makes one per run and per live stroke), and in the
    example-analysis disk cache, read back mapped, so that a tiled run's
    worker holds file pages the system can drop rather than its own copy
    of every DEM of a library (4 MB a 1200 x 850 DEM).  In memory when the
    cache is off.

    Returns
    -------
    ndarray of float32, shape of ``heights``
        Read-only: every stage and memo of the run reads it, and its hash
        is made once.
    """
    key = (array_key(heights), float(median), float(scale))

    def make() -> np.ndarray:
        stored_key = f"layout-detail-{key[0][0].hex()}-{heights.shape[0]}x{heights.shape[1]}-m{key[1]!r}-s{key[2]!r}"
        detail = cache.kept_array(stored_key, lambda: (heights - np.float32(median)) * np.float32(scale))
        detail = np.asarray(detail)  # (a plain view of a mapping: no memmap bookkeeping on every slice)
        detail.flags.writeable = False
        return detail

    return _DETAILS.get(key, make)


#: Each example detail's level spread (:func:`anchors`) by its bytes.
_SPREADS = Memo(16)


def anchors(detail: list, relief: np.ndarray, patch_size: int, valid: list | None = None) -> np.ndarray:
    """Each example's shift weight (see :class:`StyleLayout`).

    Parameters
    ----------
    detail : list of ndarray of float32, shape (H, W)
        Each example's detail heights, metres.
    relief : ndarray of float, shape (len(detail),)
        Each example's relief, metres.
    patch_size : int
        Patch side, cells.
    valid : list of (ndarray of bool, shape (H, W), or None), optional
        Where each example is real (:attr:`ExampleAnalysis.valid`).

    Returns
    -------
    ndarray of float64, shape (len(detail),)

    Notes
    -----
    The level spread (a box filter over the whole example, 0.03-0.1 s for
    a 1201x1201 one) is kept by the detail's bytes: a session is made for
    every run and every live stroke, with the same examples.  Hashing the
    bytes costs a few milliseconds.
    """
    valid = valid or [None] * len(detail)
    spreads = [_SPREADS.get((array_key(d, v), int(patch_size)), lambda d=d, v=v: level_spread(d, patch_size, v))
               for d, v in checked(zip(detail, valid))]
    return np.array([anchor_weight(float(r), spread) for spread, r in zip(spreads, relief)])

