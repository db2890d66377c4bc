"""What a run gives back: the height field, its debug maps and the record of
every patch placed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..controls.pins import PinError
from ..features import FeatureMaps
from ..heightfield import GeoReference, HeightField
from ..matching.usage import source_reuse
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
    georef : GeoReference or None
        The output's place on the map (a local Transverse Mercator, see
        :func:`~terrasynth_core.io.resample.output_georeference`).
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
    georef: GeoReference | None = None

    def to_heightfield(self, source: str | None = None) -> HeightField:
        """The heights with the run's square cell size and map placement,
        ready for :func:`~terrasynth_core.io.save_dem`."""
        cell = None if self.cell_size is None else (self.cell_size, self.cell_size)
        return HeightField(self.heights, cell_size=cell, georef=self.georef, source=source)

    def counts(self) -> dict[str, int]:
        """Patches placed by kind (branch, end, path, fill, stamp)."""
        out = {"branch": 0, "end": 0, "path": 0, "fill": 0, "stamp": 0}
        for p in self.patches:
            out[p.kind] += 1
        return out

    def source_reuse(self) -> float:
        """Largest share of the feature patches that came from one example
        window (:func:`~terrasynth_core.matching.usage.source_reuse`)."""
        return source_reuse(self.patches)

    def patch_table(self, names=None) -> list[dict]:
        """Every patch as a JSON-ready dict: kind, feature, example index
        (and name, from ``names`` per example index, when given), source
        row/col, mirrored, bbox, deformation, SSD, seam cost, cost."""
        out = []
        for i, p in enumerate(self.patches):
            row = {"index": i, "kind": p.kind, "feature": p.feature, "example": p.example}
            if names is not None and 0 <= p.example < len(names):
                row["example_name"] = names[p.example]
            row.update({"source_row": round(p.source[0], 2), "source_col": round(p.source[1], 2),
                        "mirrored": p.mirrored, "bbox": list(p.bbox), "deformation": round(p.deformation, 6),
                        "ssd": round(p.ssd, 6), "seam_cost": round(p.seam_cost, 6), "cost": round(p.cost, 6)})
            out.append(row)
        return out

    def report(self, names=None) -> dict:
        """JSON-ready summary: parameters, counts, timings, warnings, the
        source reuse and every patch (:meth:`patch_table`; ``names``: the
        examples' names by index, when known)."""
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
            "source_reuse": round(self.source_reuse(), 4),
            "patches": self.patch_table(names),
        }
