"""What a run gives back: the height field, its debug maps and the record of
every patch placed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..controls.pins import PinError
from ..features import FeatureMaps
from .params import SynthesisParams


@dataclass(frozen=True)
class PatchRecord:
    """What was placed where, and why (a debug product of the result).

    ``source`` is the example window's top-left corner for fill patches and
    the example sample centre for feature patches, ``(row, col)``; stamps
    have ``example`` -1 and ``source`` (stamp index, 0).
    """

    kind: str
    feature: str | None
    bbox: tuple[int, int, int, int]
    example: int
    source: tuple[float, float]
    mirrored: bool
    deformation: float
    ssd: float
    seam_cost: float
    cost: float


@dataclass(frozen=True, eq=False)
class SynthesisResult:
    """The output height field with its debug maps.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Synthesized heights in metres.
    patch_id : ndarray of int32, shape (rows, cols)
        Index into :attr:`patches` of the patch each cell came from.
    seam_mask : ndarray of bool, shape (rows, cols)
        Cells next to a graph-cut seam.
    patches : tuple of PatchRecord
    sketch_features : FeatureMaps
        The sketch's ridge and valley networks the run followed.
    timings : dict of str -> float
        Seconds per stage.
    total_seconds : float
    warnings : tuple of str
        Things the user should know (fallbacks, nodata handling, no strokes).
    params : SynthesisParams
    style_map : ndarray of int16, shape (rows, cols), or None
        Style label per cell (-1 = the plain examples) when styles were used.
    pin_errors : tuple of PinError
        Height minus wanted height at each pin, metres.
    selection : ndarray of bool, shape (rows, cols), or None
        The cells a local re-synthesis changed (None for a full run).
    cell_size : float or None
        Side of the output's square cells in metres (None: no example knew
        its cell size).
    """

    heights: np.ndarray
    patch_id: np.ndarray
    seam_mask: np.ndarray
    patches: tuple[PatchRecord, ...]
    sketch_features: FeatureMaps
    timings: dict
    total_seconds: float
    warnings: tuple[str, ...]
    params: SynthesisParams
    style_map: np.ndarray | None = None
    pin_errors: tuple[PinError, ...] = ()
    selection: np.ndarray | None = None
    cell_size: float | None = None

    def counts(self) -> dict[str, int]:
        """Patches placed by kind (branch, end, path, fill, stamp)."""
        out = {"branch": 0, "end": 0, "path": 0, "fill": 0, "stamp": 0}
        for p in self.patches:
            out[p.kind] += 1
        return out

    def report(self) -> dict:
        """JSON-ready summary: parameters, counts, timings, warnings."""
        return {
            "params": self.params.to_dict(),
            "shape": list(self.heights.shape),
            "cell_size": self.cell_size,
            "patch_counts": self.counts(),
            "timings": {k: round(v, 4) for k, v in self.timings.items()},
            "total_seconds": round(self.total_seconds, 4),
            "height_range": [float(self.heights.min()), float(self.heights.max())],
            "pins": [{"row": e.row, "col": e.col, "target": e.target, "height": e.height, "error": e.error}
                     for e in self.pin_errors],
            "warnings": list(self.warnings),
        }
