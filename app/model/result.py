"""The last synthesis result as the document keeps it."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from terrasynth_core.features import FeatureMaps
from terrasynth_core.heightfield import GeoReference
from terrasynth_core.synthesis import PinError


@dataclass(frozen=True, eq=False)
class TerrainResult:
    """A synthesized terrain with the debug maps the views overlay.

    Built from a core ``SynthesisResult`` after a run, or read back from a
    project file (which keeps no per-patch records).

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Heights in metres.
    patch_id : ndarray of int32, shape (rows, cols)
        Patch each cell came from, -1 for none.
    seam_mask : ndarray of bool, shape (rows, cols)
        Cells next to a seam between patches.
    sketch_features : FeatureMaps or None
        The ridge and valley networks the run followed.
    cell_size : (dy, dx) or None
        Ground size of a cell in metres (square: the run's cell size).
    report : dict
        The run's JSON-ready summary (parameters, counts, timings, pins,
        warnings).
    pin_errors : tuple of PinError
        How well each elevation pin was met (height - target, metres).
    georef : GeoReference or None
        The output's place on the map (the run's local Transverse
        Mercator); not kept in project files.
    """

    heights: np.ndarray
    patch_id: np.ndarray
    seam_mask: np.ndarray
    sketch_features: FeatureMaps | None = None
    cell_size: tuple[float, float] | None = None
    report: dict = field(default_factory=dict)
    pin_errors: tuple[PinError, ...] = ()
    georef: GeoReference | None = None

    def __post_init__(self):
        heights = np.asarray(self.heights, dtype=np.float32)
        if heights.ndim != 2:
            raise ValueError(f"result heights must be 2-D, got shape {heights.shape}")
        for name in ("patch_id", "seam_mask"):
            if np.shape(getattr(self, name)) != heights.shape:
                raise ValueError(f"result {name} has shape {np.shape(getattr(self, name))}, expected {heights.shape}")
        object.__setattr__(self, "heights", heights)
        object.__setattr__(self, "patch_id", np.asarray(self.patch_id, dtype=np.int32))
        object.__setattr__(self, "seam_mask", np.asarray(self.seam_mask, dtype=bool))
        object.__setattr__(self, "pin_errors", tuple(self.pin_errors))

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    @property
    def warnings(self) -> list[str]:
        return list(self.report.get("warnings", []))

    @property
    def seed(self) -> int | None:
        """The seed the terrain was made with, when the report says."""
        seed = self.report.get("params", {}).get("seed")
        return None if seed is None else int(seed)

    @property
    def patch_size(self) -> int | None:
        """The patch size the terrain was made with (an automatic one as
        chosen), when the report says: a change to part of it re-uses it."""
        size = self.report.get("params", {}).get("patch_size")
        return None if size is None else int(size)

    def params_for_change(self, params):
        """``params`` (SynthesisParams) for re-making part of this terrain:
        an automatic patch size becomes the one the terrain was made with."""
        return replace(params, patch_size=params.patch_size or self.patch_size)

    @property
    def relief(self) -> float:
        """Height range of the terrain, metres (max - min)."""
        return float(self.heights.max() - self.heights.min())

    @classmethod
    def from_synthesis(cls, result, *, cell_size: tuple[float, float] | None = None) -> "TerrainResult":
        """Keep what the app needs of a core ``SynthesisResult``; its own
        square cell size wins over ``cell_size`` (for a run whose examples
        know none)."""
        if getattr(result, "cell_size", None) is not None:
            cell_size = (result.cell_size, result.cell_size)
        return cls(result.heights, result.patch_id, result.seam_mask, result.sketch_features,
                   cell_size, result.report(), tuple(result.pin_errors), getattr(result, "georef", None))

    @staticmethod
    def pin_errors_of(report: dict) -> tuple[PinError, ...]:
        """The pin errors a run's :meth:`report` lists (read back from a project)."""
        return tuple(PinError(int(p["row"]), int(p["col"]), float(p["target"]), float(p["height"]),
                              float(p["error"])) for p in report.get("pins", []))
