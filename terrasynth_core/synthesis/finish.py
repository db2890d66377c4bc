"""The finished heights: height range, drainage (valleys drain, ridges
divide, closed depressions breached), the examples' range (without a
height range), water, then pins
(all in final metres), keeping every locked cell of a local re-synthesis
bit for bit."""

from __future__ import annotations

import numpy as np

from ..controls.depressions import drain_terrain, grid_factor
from ..controls.drainage import apply_drainage
from ..controls.layout import StyleLayout
from ..controls.options import Controls
from ..controls.pins import PinError, apply_pins
from ..controls.water import apply_water, flooded_land, flooded_note
from ..features import FeatureMaps


#: Share of the map under painted water from which the run says the
#: terrain is nearly all water (an inverted or all-dark mask).
ALL_WATER = 0.99

#: Share of the examples' height range, at either end, over which heights
#: beyond it are eased into it.
RANGE_KNEE = 0.03


def within_examples_range(heights: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Heights beyond ``[lo, hi]`` eased into it by a soft knee.

    Patches stack: a valley carved into low ground, a crest on high ground
    reach past the lowest and highest heights any example has (0.5-3 % of
    the cells of half the test runs on the built-ins).  Within
    :data:`RANGE_KNEE` of the range's ends heights are compressed by
    ``tanh`` (slope 1 where the knee starts, so no crease; strictly
    increasing, so no new pit or peak and streams keep their courses, to
    a few knees past the ends, beyond which float32 saturates at them), and
    nothing reaches past the ends.  Heights further inside are untouched.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres.
    lo, hi : float
        The range, metres.

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        ``heights`` itself when every height is at least the knee's width
        inside the range.
    """
    knee = RANGE_KNEE * (hi - lo)
    top, bottom = hi - knee, lo + knee
    if knee <= 0 or (heights.min() >= bottom and heights.max() <= top):
        return heights
    h = heights.astype(np.float64)
    high, low = h > top, h < bottom
    h[high] = top + knee * np.tanh((h[high] - top) / knee)
    h[low] = bottom - knee * np.tanh((bottom - h[low]) / knee)
    return h.astype(np.float32)


def _asked_range(layout: StyleLayout, heights: np.ndarray) -> tuple[float, float]:
    """The examples' height range, widened to what stamps place (their
    cores keep their own heights)."""
    lo, hi = layout.height_range()
    for st in layout.stamps:
        r0, r1, c0, c1 = st.bbox
        core = heights[r0:r1, c0:c1][st.core]
        if core.size:
            lo, hi = min(lo, float(core.min())), max(hi, float(core.max()))
    return lo, hi


def _onto(heights: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """``heights`` mapped linearly onto ``[lo, hi]`` (float32; a flat
    terrain is left as it is)."""
    span = float(heights.max() - heights.min())
    if span <= 0:
        return heights
    return (lo + (heights.astype(np.float64) - heights.min()) * ((hi - lo) / span)).astype(np.float32)


def finish_heights(heights: np.ndarray, controls: Controls, layout: StyleLayout, *, locked: np.ndarray | None,
                   patch_size: int, sketch: FeatureMaps | None = None) -> tuple[np.ndarray, tuple[PinError, ...], list[str]]:
    """Apply the height range, drainage, water and pins to synthesized heights.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Synthesized heights, metres.
    controls : Controls
        Checked controls (water, pins, pin radius, previous result).
    layout : StyleLayout
        Its ``remap`` gives the height range.
    locked : ndarray of bool, shape (rows, cols), or None
        Cells of a local re-synthesis that keep their previous heights;
        None for a full run (the height range applies only then).
    patch_size : int
        Sets the widths of the drainage step and of the water's banks (half
        a patch).
    sketch : FeatureMaps, optional
        The sketch's ridges and valleys in output cells: given, valleys are
        made to drain and ridges to divide, and the terrain's other closed
        depressions are breached (None: no drainage step).

    Returns
    -------
    heights : ndarray of float32, shape (rows, cols)
    pin_errors : tuple of PinError
    notes : list of str
        Warnings for the result (flooded land, pins outside the selection).
    """
    notes = []
    ranged = layout.remap is not None and locked is None
    if ranged:
        heights = _onto(heights, *layout.remap[:2])
    if sketch is not None:
        water = None if controls.water is None else controls.water.mask
        heights = apply_drainage(heights, sketch.valleys, sketch.ridges, patch_size=patch_size, water=water,
                                 locked=locked)
        # The rest of the terrain drains too: its closed depressions are
        # breached, the painted ridges as walls (but for a basin of painted valleys).
        heights = drain_terrain(heights, factor=grid_factor(patch_size, heights.shape), ridges=sketch.ridges,
                                valleys=sketch.valleys, water=water, locked=locked)
        if ranged:
            # (The drainage cut some floors a little below the range and
            # breached rims; mapped onto it again, linearly, every descent
            # stays one.)
            heights = _onto(heights, *layout.remap[:2])
    if layout.remap is None:
        # (After drainage, which may carve a valley floor below the range:
        # the knee keeps every descent a descent.)
        heights = within_examples_range(heights, *_asked_range(layout, heights))
        if locked is not None:
            # (The knee maps every cell; the water and pins below read the
            # locked cells as they will stay.)
            heights = np.where(locked, controls.previous, heights).astype(np.float32)
    if controls.water is not None:
        covered = float(controls.water.mask.mean())
        if covered >= ALL_WATER:
            notes.append(f"the water mask covers {100 * covered:.0f} % of the map: the terrain under it is water, "
                         f"below {controls.water.level:g} m, sketch and all; paint water only where it should be")
        heights = apply_water(heights, controls.water, bank_width=patch_size / 2, locked=locked)
        flooded = flooded_land(heights, controls.water)
        if flooded:
            notes.append(flooded_note(flooded, controls.water.level))
    # A pin near the shore must not lift painted water above its level: the
    # pins' correction bends around water as around locked cells.
    held = locked
    if controls.water is not None:
        held = controls.water.mask if locked is None else locked | controls.water.mask
    heights, pin_errors = apply_pins(heights, controls.pins, radius=controls.pin_reach(patch_size), locked=held)
    for e in pin_errors:
        if locked is not None and locked[e.row, e.col]:
            notes.append(f"pin at ({e.row}, {e.col}) is outside the selection: left as it was")
        elif held is not None and held[e.row, e.col]:
            notes.append(f"pin at ({e.row}, {e.col}) is on painted water: the water level wins")
    if locked is not None:
        # Every step above keeps locked cells; this makes the promise
        # explicit (bit-identical outside the selection).
        heights = np.where(locked, controls.previous, heights).astype(np.float32)
    return heights, pin_errors, notes
