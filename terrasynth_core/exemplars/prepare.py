"""Per-example preparation: valid heights, feature networks, relief scale.

Extracting an example's ridges and valleys is the slowest part of starting a
run, and the same examples are used run after run (the app re-synthesizes
after every edit), so the analysis is memoised per (heights, patch size), in
memory and on disk (:mod:`.cache`).
"""

from __future__ import annotations

import hashlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..measures import topographic_position_index
from ..errors import ParamsError
from ..features import FeatureMaps, extract_features
from ..features.ppa import spare_core
from ..heightfield import HeightField, largest_valid_rectangle
from . import cache
from ..features.samples import example_samples


@dataclass(frozen=True, eq=False)
class ExampleAnalysis:
    """An example ready for synthesis.

    Parameters
    ----------
    heights : ndarray of float32, shape (H, W)
        Valid heights (nodata cropped or filled).
    features : FeatureMaps
    samples : dict kind -> list of FeatureSample
        Candidate feature patch centres.
    strong_mask : ndarray of bool, shape (H, W)
        Cells on long features, kept out of fill patches.
    relief : float
        Typical height spread within a patch (median local standard
        deviation, metres): the unit costs are measured in.
    note : str or None
        What was done about nodata, for the run's warnings.
    key : str
        What the analysis is of (the heights' digest, their shape and the
        patch size): equal keys, equal analyses.  Memos of what is made
        from an analysis key by it, so an analysis read again from the
        disk cache (a new object) still finds them.
    """

    heights: np.ndarray
    features: FeatureMaps
    samples: dict
    strong_mask: np.ndarray
    relief: float
    note: str | None
    key: str


def prepare_example(field: HeightField | np.ndarray, patch_size: int, *, name: str = "example") -> ExampleAnalysis:
    """Make an example ready: handle nodata, check its size, analyse it.

    Raises
    ------
    ParamsError
        When the example (after removing nodata) is smaller than a patch.
    """
    if not isinstance(field, HeightField):
        field = HeightField(np.asarray(field, dtype=np.float32), source=name)
    note = None
    if field.nodata_count:
        r0, r1, c0, c1 = largest_valid_rectangle(~field.nodata)
        if min(r1 - r0, c1 - c0) >= 2 * patch_size:
            note = f"{name}: cropped to its largest valid rectangle {r1 - r0}x{c1 - c0} (nodata)"
            field = field.window(r0, r1, c0, c1)
        else:
            note = f"{name}: {field.nodata_count} nodata cells filled from their neighbours"
            field = field.fill_nodata()
    if min(field.shape) < patch_size + 4:
        raise ParamsError(
            f"{name} is {field.shape[0]}x{field.shape[1]} cells (valid part), smaller than a patch of "
            f"{patch_size}x{patch_size}: use a larger example or a smaller patch size"
        )
    heights = np.ascontiguousarray(field.heights, dtype=np.float32)
    if not np.ptp(heights):
        flat = (f"{name} is flat (every cell {heights.flat[0]:g} m): it has no relief to give, "
                "the terrain will be flat")
        note = flat if note is None else f"{note}; {flat}"
    digest = hashlib.sha1(heights.tobytes()).hexdigest()
    key = f"{digest}-{heights.shape[0]}x{heights.shape[1]}-p{patch_size}"
    features, samples, strong, relief = _CACHE.get(key, lambda: _analyse(heights, patch_size))
    return ExampleAnalysis(heights, features, samples, strong, relief, note, key)


#: Example feature samples weaker than this quantile of their kind are dropped...
STRONG_QUANTILE = 0.5
#: ...unless they stand out by at least this many standard deviations of TPI.
MIN_STRENGTH = 1.0

# In memory too: the app re-synthesizes after every edit.
_CACHE = cache.Memo(8, cache.load, lambda key, value: cache.save(key, *value))


def _analyse(heights: np.ndarray, patch_size: int) -> tuple:
    """The analysis :data:`_CACHE` stores: ``(features, samples, strong, relief)``.

    With a core to spare (:func:`~terrasynth_core.features.ppa.spare_core`)
    the TPI and the relief, which need no features, are computed on a
    second thread while PPA runs (its ridge and valley threads rarely finish
    together, and the FFTs release the GIL), and the two networks' samples
    are then taken on two threads.  Every part is computed exactly as alone.
    """
    radius = patch_size / 2
    if spare_core():
        with ThreadPoolExecutor(max_workers=2, thread_name_prefix="analysis") as pool:
            tpi_and_relief = pool.submit(_tpi_and_relief, heights, radius, patch_size)
            features = extract_features(heights)
            tpi, relief = tpi_and_relief.result()
            pools = list(pool.map(_sample_pool, (features.ridges, features.valleys), (1.0, -1.0),
                                  (tpi, tpi), (radius, radius)))
    else:
        features = extract_features(heights)
        tpi, relief = _tpi_and_relief(heights, radius, patch_size)
        pools = [_sample_pool(features.ridges, 1.0, tpi, radius), _sample_pool(features.valleys, -1.0, tpi, radius)]
    samples = {"ridge": pools[0], "valley": pools[1]}
    strong = np.zeros(heights.shape, dtype=bool)
    for graph in (features.ridges, features.valleys):
        long_paths = tuple(p for p in graph.paths if p.length >= patch_size)
        if long_paths:
            strong |= type(graph)(graph.kind, graph.shape, graph.nodes, long_paths).rasterize()
    strong = ndimage.binary_dilation(strong, iterations=2)
    return features, samples, strong, relief


def _tpi_and_relief(heights: np.ndarray, radius: float, patch_size: int) -> tuple[np.ndarray, float]:
    """The TPI in standard deviations, shape (H, W) float32, and the relief.

    The TPI tells how far a sample's centre stands above (ridge) or below
    (valley) the patch around it: PPA finds every little spur, but a
    sketched stroke asks for a real ridge or valley.  The relief is the
    median local standard deviation within a patch, in metres.
    """
    tpi = topographic_position_index(heights, radius=radius)
    tpi /= float(np.nanstd(tpi)) or 1.0
    mean = ndimage.uniform_filter(heights.astype(np.float64), patch_size)
    mean2 = ndimage.uniform_filter(heights.astype(np.float64) ** 2, patch_size)
    local_std = np.sqrt(np.maximum(mean2 - mean**2, 0.0))
    return tpi, float(np.median(local_std)) or 1.0


def _sample_pool(graph, sign: float, tpi: np.ndarray, radius: float) -> list:
    """The candidate samples of one network: centres that leave room for
    the patch (and a little warp) inside the example, standing out enough
    by TPI (``sign`` +1 for ridges, -1 for valleys)."""
    margin = radius * 1.1
    H, W = tpi.shape
    pool = [
        s for s in example_samples(graph, radius, spacing=radius / 2)
        if margin <= s.center[0] <= H - 1 - margin and margin <= s.center[1] <= W - 1 - margin
    ]
    if pool:
        rc = np.rint([s.center for s in pool]).astype(int)
        strength = sign * tpi[rc[:, 0], rc[:, 1]]
        keep = strength >= min(np.quantile(strength, STRONG_QUANTILE), MIN_STRENGTH)
        pool = [s for s, k in zip(pool, keep) if k]
    return pool
