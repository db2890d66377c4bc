"""Stamps too thin to place, refused before a run with the numbers that fix them.

The engine places a stamp's core and merges an outer band of at least 2
cells a side through the seam solve
(:func:`terrasynth_core.controls.stamps.render_stamp`); a footprint under
:data:`MIN_STAMP_CELLS` output cells across has no core left, and under 16
cells in all the engine only says it "covers fewer than 16 output cells".
A long thin window (a ridge crest cut out as 200x10 cells) at a small scale
is the usual case.  Checked here, in the front ends' shared path (the CLI
and :meth:`~terrasynth_core.project.RunSpec.make_session`, which the app
runs), with the window's footprint, the run's cell size and the scale
that would do.
"""

from __future__ import annotations

from typing import Sequence

from ..controls.options import check_stamp_transform
from ..errors import ParamsError
from ..exemplars.ground import run_cell_size
from ..heightfield import HeightField
from ..synthesis import Controls

__all__ = ["MIN_STAMP_CELLS", "check_stamp_footprints"]

#: Fewest output cells a stamp's footprint must span across: its 2-cell seam
#: band on both sides and one protected cell between.
MIN_STAMP_CELLS = 5


def check_stamp_footprints(controls: Controls | None, examples: Sequence, cell_size: float | None) -> None:
    """Refuse a stamp whose footprint is thinner than :data:`MIN_STAMP_CELLS`.

    Parameters
    ----------
    controls : Controls or None
        Its stamps are checked.
    examples : sequence of HeightField or ndarray
        The plain examples (with the styles' and the stamps' DEMs they set
        the run's cell size when ``cell_size`` is None).
    cell_size : float or None
        ``SynthesisParams.cell_size``.

    Raises
    ------
    ParamsError
        Naming the stamp, its window, its footprint in output cells and the
        smallest scale that makes it wide enough.
    """
    if controls is None or not controls.stamps:
        return
    fields = [*examples, *(s.example for s in controls.styles), *(st.field for st in controls.stamps)]
    cell = run_cell_size(cell_size, fields)
    for index, stamp in enumerate(controls.stamps, 1):
        field = stamp.field
        # (The transform first: the footprint's size means nothing at a scale out of range.)
        check_stamp_transform(stamp.scale, stamp.rotation, f"stamp {index}")
        rows, cols = field.shape
        if stamp.window is not None:
            r0, r1, c0, c1 = (int(v) for v in stamp.window)
            rows, cols = max(r1 - r0, 0), max(c1 - c0, 0)
        if rows == 0 or cols == 0:
            continue  # an empty or reversed window: the engine names it
        true = (1.0, 1.0)
        if cell is not None and isinstance(field, HeightField) and field.cell_size is not None:
            true = (field.cell_size[0] / cell, field.cell_size[1] / cell)
        across = min(rows * true[0], cols * true[1])  # output cells at scale 1
        if across * stamp.scale >= MIN_STAMP_CELLS:
            continue
        name = getattr(field, "source", None) or "an array"
        on = "" if cell is None else f" of {cell:g} m"
        raise ParamsError(
            f"stamp {index} ({name}, a {rows}x{cols}-cell window) at scale {stamp.scale:g} is "
            f"{rows * true[0] * stamp.scale:.1f} x {cols * true[1] * stamp.scale:.1f} output cells{on}: "
            f"a stamp must be at least {MIN_STAMP_CELLS} cells across; give a scale of at least "
            f"{MIN_STAMP_CELLS / across:.2g} or a wider window")
