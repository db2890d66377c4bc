"""Ridge and valley extraction from a DEM with PPA.

The Profile recognition and Polygon breaking Algorithm (Chang, Song and Hsu
1998), as Zhou et al. (2007, section 3) use it to find the features of an
example DEM:

1. *Profile recognition* (:func:`profile_targets`): a cell is a target when,
   along at least one of the four profiles through it (N-S, E-W, NE-SW,
   NW-SE), both sides hold a lower cell within half a profile length, and
   both drop by at least ``min_drop`` metres.
2. *Target connection* and *polygon breaking*: 8-adjacent targets are linked,
   a link as strong as the heights of its ends, and a maximum spanning forest
   keeps the strongest acyclic subset (:mod:`.network`).
3. *Branch reduction* and *line smoothing* (:mod:`.network`).

Valleys are ridges of the negated heights.

References
----------
Chang, Y.-C., Song, G.-S., Hsu, S.-K. (1998). Automatic extraction of ridge
and valley axes using the profile recognition and polygon-breaking algorithm.
Computers & Geosciences 24(1):83-93.

Zhou, H., Sun, J., Turk, G., Rehg, J. M. (2007). Terrain synthesis from
digital elevation models. IEEE TVCG 13(4):834-848.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..heightfield import height_grid
from .graph import FeatureGraph, FeatureKind, FeatureMaps
from .network import feature_graph_from_mask

#: The four profile directions ``(drow, dcol)``: E-W, N-S, NW-SE, NE-SW.
PROFILE_DIRECTIONS = ((0, 1), (1, 0), (1, 1), (1, -1))

#: Grids of at least this many cells extract ridges and valleys on two
#: threads (below, starting threads costs more than it saves).
THREADED_CELLS = 250_000


def spare_core() -> bool:
    """Whether a second thread would find a core to run on.

    Two threads only pay when a core is idle: on a machine whose cores are
    all busy (load average at or above the core count) the interpreter
    lock changes hands behind the other processes' time slices, and
    measured here PPA took 1.05-1.5x the wall time of one thread, against
    0.6x at a load of 2 on 2 cores.  The result is the same either way.
    """
    cores = os.cpu_count() or 1
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):  # no load average on this platform (Windows)
        load = 0.0
    return cores >= 2 and load < cores


@dataclass(frozen=True)
class PPAParams:
    """Parameters of PPA feature extraction; validated on construction.

    The defaults work across the bundled DEMs (30 m to 93 m cells, 1,000 m
    to 6,000 m of relief) at their native resolution.

    Parameters
    ----------
    profile_length : int, default 7
        Length of the profiles in cells, odd, 3 to 15.  A target needs a
        lower cell within ``profile_length // 2`` cells on both sides.
    min_drop : float or None, default None
        Least drop in metres from a target to the lowest cell on each side of
        its profile.  None derives it from the grid: ``relative_drop`` times
        the median local relief (highest minus lowest height in a
        ``profile_length`` square window), so it scales from plateaus to the
        Himalaya.  0 keeps PPA's bare "strictly lower" test.
    relative_drop : float, default 0.15
        Fraction of the median local relief used when ``min_drop`` is None;
        0 to 1.  Broad, rounded ridges whose crest falls less than this
        within half a profile are missed: lengthen the profile or lower
        the fraction for them.
    prune_length : float, default 12.0
        End branches shorter than this many cells are removed (PPA's short
        false ridges beside the true ones).
    prune_iterations : int, default 3
        Rounds of end-branch removal, 0 to 100.
    min_component_length : float, default 30.0
        Isolated ridge or valley networks shorter than this many cells in
        total are dropped.
    smoothing : int, default 5
        Moving-average window along the paths, in points; 0 or 1 = none.
    junction_merge_distance : float, default 2.0
        Branch points this close (in cells, along the path between them) are
        merged into one node.
    """

    profile_length: int = 7
    min_drop: float | None = None
    relative_drop: float = 0.15
    prune_length: float = 12.0
    prune_iterations: int = 3
    min_component_length: float = 30.0
    smoothing: int = 5
    junction_merge_distance: float = 2.0

    def __post_init__(self):
        validate_int(self, "profile_length", 3, 15)
        if self.profile_length % 2 == 0:
            raise ParamsError(f"PPAParams.profile_length must be odd, got {self.profile_length}")
        if self.min_drop is not None:
            validate_number(self, "min_drop", 0.0, math.inf)
        validate_number(self, "relative_drop", 0.0, 1.0)
        validate_number(self, "prune_length", 0.0, math.inf)
        validate_int(self, "prune_iterations", 0, 100)
        validate_number(self, "min_component_length", 0.0, math.inf)
        validate_int(self, "smoothing", 0, 1000)
        validate_number(self, "junction_merge_distance", 0.0, math.inf)


def validate_int(params, name: str, low: int, high: int) -> None:
    """Raise :class:`ParamsError` naming ``Class.name`` unless the field is
    an integer (not a bool) from ``low`` to ``high``."""
    value = getattr(params, name)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise ParamsError(
            f"{type(params).__name__}.{name} must be an integer from {low} to {high}, got {value!r}"
        )


def validate_number(params, name: str, low: float, high: float) -> None:
    """Raise :class:`ParamsError` naming ``Class.name`` unless the field is
    a finite real number from ``low`` to ``high``."""
    value = getattr(params, name)
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool)
    if not ok or not math.isfinite(value) or not low <= value <= high:
        upper = "" if math.isinf(high) else f" and at most {high:g}"
        raise ParamsError(
            f"{type(params).__name__}.{name} must be a finite number at least {low:g}{upper}, got {value!r}"
        )


def _as_heights(heights) -> np.ndarray:
    """The float32 height grid of an array or a :class:`HeightField`, finite or NaN."""
    h = height_grid(heights, min_side=3)
    if np.isinf(h).any():
        raise ParamsError("heights hold infinite values; use NaN for nodata")
    return h


def auto_min_drop(heights: np.ndarray, profile_length: int, relative_drop: float) -> float:
    """The default least drop of a profile, in metres.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        NaN = nodata.
    profile_length : int
        Window size in cells.
    relative_drop : float
        Fraction of the median local relief.

    Returns
    -------
    float
        ``relative_drop`` times the median, over valid cells, of the highest
        minus the lowest height in a ``profile_length`` square window (0 for a
        grid without any valid cell).
    """
    valid = ~np.isnan(heights)
    if valid.all():  # the usual case: no copies with nodata masked out
        relief = ndimage.maximum_filter(heights, size=profile_length)
        relief -= ndimage.minimum_filter(heights, size=profile_length)
        return float(relative_drop * np.median(relief))
    if not valid.any():
        return 0.0
    high = ndimage.maximum_filter(np.where(valid, heights, -np.inf), size=profile_length)
    low = ndimage.minimum_filter(np.where(valid, heights, np.inf), size=profile_length)
    return float(relative_drop * np.median((high - low)[valid]))


def profile_targets(heights: np.ndarray, *, profile_length: int, min_drop: float) -> np.ndarray:
    """PPA profile recognition: the cells that are local maxima across a profile.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        NaN = nodata; NaN cells are never targets and never count as lower.
    profile_length : int
        Odd profile length in cells.
    min_drop : float
        Least drop in metres on both sides (cells must also be strictly
        lower, so 0 is PPA's plain test).

    Returns
    -------
    ndarray of bool, shape (rows, cols)
    """
    half = profile_length // 2
    rows, cols = heights.shape
    # Outside the grid and nodata count as "not lower": +inf.
    padded = np.pad(np.where(np.isnan(heights), np.inf, heights), half, constant_values=np.inf)
    threshold = heights - np.float32(min_drop)
    target = np.zeros(heights.shape, dtype=bool)
    for dr, dc in PROFILE_DIRECTIONS:
        sides = []
        for sign in (1, -1):
            lowest = np.full(heights.shape, np.inf, dtype=np.float32)
            for k in range(1, half + 1):
                r0, c0 = half + sign * k * dr, half + sign * k * dc
                np.minimum(lowest, padded[r0 : r0 + rows, c0 : c0 + cols], out=lowest)
            sides.append((lowest < heights) & (lowest <= threshold))
        target |= sides[0] & sides[1]
    return target


def extract_ridges(
    heights, *, params: PPAParams = PPAParams(), mask: np.ndarray | None = None
) -> FeatureGraph:
    """Ridges of a DEM as a feature graph; see :func:`extract_features`."""
    return extract_features(heights, kind="ridge", params=params, mask=mask).ridges


def extract_valleys(
    heights, *, params: PPAParams = PPAParams(), mask: np.ndarray | None = None
) -> FeatureGraph:
    """Valleys of a DEM as a feature graph; see :func:`extract_features`."""
    return extract_features(heights, kind="valley", params=params, mask=mask).valleys


def extract_features(
    heights,
    *,
    kind: Literal["both", "ridge", "valley"] = "both",
    params: PPAParams = PPAParams(),
    mask: np.ndarray | None = None,
) -> FeatureMaps:
    """Extract ridges and/or valleys of a DEM with PPA.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols), or HeightField
        Heights in metres, NaN = nodata.  Not modified.
    kind : {"both", "ridge", "valley"}, default "both"
        Which features to extract; the other graph comes back empty.
    params : PPAParams
    mask : ndarray of bool, shape (rows, cols), or None
        Where features may lie (True); cells outside cannot be targets but
        their heights still shape the profiles.  None = everywhere.

    Returns
    -------
    FeatureMaps
        ``ridges`` and ``valleys``, each an acyclic :class:`FeatureGraph`
        with positions in ``(row, col)`` cells.

    Raises
    ------
    ParamsError
        Bad ``kind``, ``params``, ``mask`` or heights.
    """
    if kind not in ("both", "ridge", "valley"):
        raise ParamsError(f"kind must be 'both', 'ridge' or 'valley', got {kind!r}")
    if not isinstance(params, PPAParams):
        raise ParamsError(f"params must be a PPAParams, got {type(params).__name__}")
    h = _as_heights(heights)
    if mask is not None:
        mask = np.asarray(mask)
        if mask.shape != h.shape or mask.dtype != bool:
            raise ParamsError(
                f"mask must be a boolean array of shape {h.shape}, got {mask.dtype} array of shape {mask.shape}"
            )
    min_drop = params.min_drop
    if min_drop is None:
        min_drop = auto_min_drop(h, params.profile_length, params.relative_drop)

    wanted = [k for k in ("ridge", "valley") if kind in ("both", k)]

    def one(feature_kind: FeatureKind) -> FeatureGraph:
        return _extract_one(h if feature_kind == "ridge" else -h, feature_kind, params, min_drop, mask)

    if len(wanted) == 2 and h.size >= THREADED_CELLS and spare_core():
        # Ridges and valleys are independent and their numpy and scipy
        # passes mostly run without the GIL: one thread each (the same
        # graphs, since each is computed exactly as alone).
        with ThreadPoolExecutor(max_workers=2, thread_name_prefix="ppa") as pool:
            graphs = dict(zip(wanted, pool.map(one, wanted)))
    else:
        graphs = {k: one(k) for k in wanted}
    empty = {k: FeatureGraph(k, h.shape, (), ()) for k in ("ridge", "valley") if k not in graphs}
    graphs.update(empty)
    return FeatureMaps(ridges=graphs["ridge"], valleys=graphs["valley"])


def _extract_one(
    heights: np.ndarray, kind: FeatureKind, params: PPAParams, min_drop: float, mask: np.ndarray | None
) -> FeatureGraph:
    """Ridges of ``heights`` (pass negated heights for valleys)."""
    targets = profile_targets(heights, profile_length=params.profile_length, min_drop=min_drop)
    if mask is not None:
        targets &= mask
    return feature_graph_from_mask(
        targets,
        heights,
        kind=kind,
        prune_length=params.prune_length,
        prune_iterations=params.prune_iterations,
        min_component_length=params.min_component_length,
        junction_merge_distance=params.junction_merge_distance,
        smoothing=params.smoothing,
    )


__all__ = [
    "PPAParams",
    "PROFILE_DIRECTIONS",
    "auto_min_drop",
    "extract_features",
    "extract_ridges",
    "extract_valleys",
    "profile_targets",
]
