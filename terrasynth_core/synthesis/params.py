"""Every knob of a synthesis run, in one frozen, validated object."""

from __future__ import annotations

import numbers
import os
from dataclasses import asdict, dataclass, fields
from typing import Literal

from ..errors import ParamsError
from ..exemplars.patch_size import DEFAULT_PATCH


@dataclass(frozen=True)
class SynthesisParams:
    """Parameters of :class:`~terrasynth_core.synthesis.Session`.

    Parameters
    ----------
    patch_size : int or None, default None
        Side of a square patch in output cells.  None: automatic, the
        paper's 80, or down to 32 for examples that hold too few distinct
        feature windows at 80
        (:func:`~terrasynth_core.exemplars.patch_size.fitting_patch_size`;
        the session says why in its warnings, and its ``params`` hold the
        size chosen).  A re-synthesis of part of a terrain chooses it as a
        run of the whole map would for its strokes: give it the terrain's
        own ``result.params`` to keep the size the terrain was made with.
    overlap : int or None, default None
        Width in cells of the band a fill patch shares with its neighbours;
        ``None`` is a third of the patch, as in the paper.
    k : int, default 3
        Candidates that get the full evaluation: after the cheap ranking
        (thin-plate deformation for feature patches, of which the best ``3k``
        are warped and compared with the overlap; coarse FFT SSD for fill
        patches), the best ``k`` by overlap SSD get a graph cut and the pick
        is the least SSD plus seam cost (plus deformation).
    seed : int, default 0
        Seeds every random choice; the same seed gives the same bytes.
    order : {"bfs", "raster"}, default "bfs"
        Feature patch placement order: breadth-first over the sketch's
        feature tree (the paper) or top-to-bottom, left-to-right.
    seam : {"cut", "paste"}, default "cut"
        ``"cut"``: graph-cut seam in the overlap; ``"paste"``: the new patch
        simply covers the overlap (for comparison).
    blend : {"poisson", "c1", "none"}, default "c1"
        Seam removal after the cut: the paper's Poisson solve with zero
        gradient across the seam, the same solve with the slope carried across
        the seam (first-derivative continuity), or nothing.
    mirror : bool, default True
        Add each example feature patch's mirror image to the candidate pool.
    coarse_factor : int, default 0
        Down-sampling of the example for the FFT search of fill patches; the
        best positions are then refined at full resolution.  0 chooses it
        from the example's size (about 160,000 cells searched per example).
    workers : int, default 0
        Processes that fill windows (this one and ``workers - 1`` worker
        processes); 0 uses every core.  The result does not depend on it.
    feature_weight : float, default 1.0
        Weight of the deformation cost against the overlap SSD when picking
        among feature candidates.
    cell_size : float or None, default None
        Side of the output's square cells on the ground, in metres; every
        example is resampled to it once.  None: the finest example's ground
        cell size (examples without a known cell size are taken to be at
        it; when none has one, examples are used cell for cell).
    drainage : bool, default True
        Shape the finished heights so painted valleys drain to an outlet
        (the border, water or their lowest end) and painted ridges are not
        cut by a stream (:mod:`~terrasynth_core.controls.drainage`), and
        breach the rest of the terrain's closed depressions, the painted
        ridges as walls (:mod:`~terrasynth_core.controls.depressions`).
    landform : bool, default True
        First synthesize the problem on a grid four times coarser, where a
        patch spans whole landforms, and build the detail on that terrain
        (:mod:`~terrasynth_core.synthesis.landform`); False: one pass on a
        flat level per style region, as in the paper.
    """

    patch_size: int | None = None
    overlap: int | None = None
    k: int = 3
    seed: int = 0
    order: Literal["bfs", "raster"] = "bfs"
    seam: Literal["cut", "paste"] = "cut"
    blend: Literal["poisson", "c1", "none"] = "c1"
    mirror: bool = True
    coarse_factor: int = 0
    workers: int = 0
    feature_weight: float = 1.0
    cell_size: float | None = None
    drainage: bool = True
    landform: bool = True

    def __post_init__(self):
        def bad(name, expected):
            raise ParamsError(f"parameter {name}={getattr(self, name)!r}: expected {expected}")

        if self.patch_size is not None and (
            isinstance(self.patch_size, bool) or not isinstance(self.patch_size, int)
            or not 16 <= self.patch_size <= 512
        ):
            bad("patch_size", "an integer from 16 to 512 cells, or None (automatic)")
        # (An automatic patch is at most the default; the session checks the
        # overlap again against the size it chooses.)
        half = (self.patch_size or DEFAULT_PATCH) // 2
        if self.overlap is not None and (not isinstance(self.overlap, int) or not 2 <= self.overlap <= half):
            bad("overlap", f"an integer from 2 to {half} (half the patch) or None")
        if not isinstance(self.k, int) or not 1 <= self.k <= 64:
            bad("k", "an integer from 1 to 64")
        if not isinstance(self.seed, int) or self.seed < 0:
            bad("seed", "a non-negative integer")
        if self.order not in ("bfs", "raster"):
            bad("order", "'bfs' or 'raster'")
        if self.seam not in ("cut", "paste"):
            bad("seam", "'cut' or 'paste'")
        if self.blend not in ("poisson", "c1", "none"):
            bad("blend", "'poisson', 'c1' or 'none'")
        if not isinstance(self.coarse_factor, int) or not 0 <= self.coarse_factor <= 8:
            bad("coarse_factor", "an integer from 0 (automatic) to 8")
        if not isinstance(self.workers, int) or self.workers < 0:
            bad("workers", "a non-negative integer (0 = all cores)")
        if not (self.feature_weight >= 0):
            bad("feature_weight", "a non-negative number")
        if self.cell_size is not None and (
            isinstance(self.cell_size, bool) or not isinstance(self.cell_size, numbers.Real)
            or not 0 < self.cell_size < float("inf")
        ):
            bad("cell_size", "a positive number of metres or None (the finest example's)")
        if not isinstance(self.drainage, bool):
            bad("drainage", "True or False")
        if not isinstance(self.landform, bool):
            bad("landform", "True or False")

    @property
    def overlap_cells(self) -> int:
        """The overlap actually used: ``overlap`` or a third of the patch
        (once the session has chosen an automatic patch size)."""
        if self.overlap is not None:
            return self.overlap
        if self.patch_size is None:
            raise ParamsError("the overlap of an automatic patch size is known once a session has chosen the size "
                              "(its params)")
        return max(2, self.patch_size // 3)

    def coarse_factor_for(self, example_shape: tuple[int, int]) -> int:
        """The FFT search down-sampling used for an example of this shape."""
        if self.coarse_factor:
            return self.coarse_factor
        rows, cols = example_shape
        return max(1, min(8, round((rows * cols / 160_000) ** 0.5)))

    @property
    def thread_count(self) -> int:
        """Processes the fill uses (``workers``, or one per core)."""
        return self.workers or (os.cpu_count() or 1)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "SynthesisParams":
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ParamsError(f"unknown synthesis parameter(s): {', '.join(unknown)}")
        return cls(**data)
