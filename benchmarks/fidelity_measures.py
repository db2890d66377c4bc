"""Measures of sketch fidelity used by ``eval_fidelity.py`` (issue 10).

Each function looks only at heights, masks or the result's patch records,
never at how the engine works, so any synthesis method is scored alike.
The TPI along strokes is the core's
:func:`~terrasynth_core.measures.feature_tpi_score`; the seam statistic and
"share of cells near a target" come from ``eval_synthesis.py``.

The D8 streams need the ``bench`` extra (``pip install -e .[bench]``):
RichDEM (``richdem2`` on PyPI) fills the depressions and accumulates the
flow; it is imported only inside :func:`d8_streams`, so the other measures
work without it.
"""

from __future__ import annotations

import contextlib
import os
import sys

import numpy as np

#: Octave bands of the power spectrum, wavelengths in cells (short, long).
OCTAVES = ((8, 16), (16, 32), (32, 64), (64, 128))


def height_percentile(heights: np.ndarray, cells: np.ndarray) -> float:
    """Mean height percentile (0 = lowest cell of the grid, 1 = highest) of ``cells``.

    Parameters
    ----------
    heights : ndarray, shape (rows, cols)
    cells : ndarray of bool, same shape
        The cells to rate, e.g. a sketch's ridge strokes.

    Returns
    -------
    float
        Mean over ``cells`` of the share of the grid's cells strictly
        lower than the cell (ties count half); NaN when ``cells`` is empty.
    """
    if not cells.any():
        return float("nan")
    flat = np.sort(np.ravel(heights))
    values = heights[cells]
    below = np.searchsorted(flat, values, side="left")
    not_above = np.searchsorted(flat, values, side="right")
    return float(np.mean((below + not_above) / 2.0) / flat.size)


def wrong_half(heights: np.ndarray, cells: np.ndarray, *, high: bool) -> float:
    """Share of ``cells`` in the wrong half of the grid's heights: below
    its median where they should stand high (``high``: ridges), above it
    where they should lie low (valleys).

    The mean percentile (:func:`height_percentile`) hides a stretch of
    ridge that runs through lowland behind the rest of it standing high;
    this counts that stretch.

    Returns
    -------
    float
        0 to 1; NaN when ``cells`` is empty.
    """
    if not cells.any():
        return float("nan")
    median = float(np.median(heights))
    values = np.asarray(heights)[cells]
    return float(np.mean(values < median if high else values > median))


@contextlib.contextmanager
def _quiet_fds():
    """Silence the C++ library's own prints to stdout and stderr."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    with open(os.devnull, "w") as null:
        try:
            os.dup2(null.fileno(), 1)
            os.dup2(null.fileno(), 2)
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)


def d8_accumulation(heights: np.ndarray) -> np.ndarray:
    """D8 flow accumulation (cells draining through each cell, itself
    included) on the depression-filled heights, by RichDEM.

    Depressions are filled with an epsilon gradient (Barnes et al. 2014), so
    flats drain too; water leaves the grid at its border.
    """
    import richdem as rd

    filled = filled_depressions(heights, epsilon=True)
    with _quiet_fds():
        accumulation = rd.FlowAccumulation(filled, method="D8")
    return np.asarray(accumulation, dtype=np.float64)


def filled_depressions(heights: np.ndarray, *, epsilon: bool):
    """``heights`` with every closed depression filled to its spill level
    (RichDEM's priority flood, water leaving at the grid's border), as a
    RichDEM array; ``epsilon``: flats rise by the least step so they drain
    (Barnes et al. 2014)."""
    import richdem as rd

    dem = rd.rdarray(np.asarray(heights, dtype=np.float64).copy(), no_data=-1e30,
                     geotransform=(0.0, 1.0, 0.0, 0.0, 0.0, -1.0))
    with _quiet_fds():
        return rd.FillDepressions(dem, epsilon=epsilon)


def d8_streams(heights: np.ndarray, *, area_share: float = 1 / 2000) -> np.ndarray:
    """Stream cells: D8 accumulation (:func:`d8_accumulation`) of at least
    ``area_share`` of the grid's cells."""
    return d8_accumulation(heights) >= area_share * heights.size


def closed_depressions(heights: np.ndarray, *, depth_share: float = 0.01) -> float:
    """Share of cells in a closed depression deeper than ``depth_share`` of
    the relief (:func:`relief`): how far below their spill level
    (:func:`filled_depressions`) they lie.  Real terrain drains: the
    built-in examples hold 0-2.4 % at 1 %."""
    h = np.asarray(heights, dtype=np.float64)
    filled = np.asarray(filled_depressions(h, epsilon=False), dtype=np.float64)
    return float(np.mean(filled - h > depth_share * relief(h)))


def relief(heights: np.ndarray, *, tail: float = 0.5) -> float:
    """Height span between the ``tail`` and ``100 - tail`` percentiles."""
    low, high = np.percentile(heights, [tail, 100.0 - tail])
    return float(high - low)


def share_out_of_range(heights: np.ndarray, reference: np.ndarray) -> float:
    """Share of ``heights`` below the reference's minimum or above its maximum."""
    low, high = float(np.nanmin(reference)), float(np.nanmax(reference))
    h = np.asarray(heights)
    return float(np.mean((h < low) | (h > high)))


def welch_spectrum(heights: np.ndarray, *, tile: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Radially averaged power spectrum, Welch estimate.

    The grid is cut into ``tile`` x ``tile`` tiles overlapping by half (the
    last row and column of tiles end at the border); each tile, less its
    mean, is multiplied by a 2-D Hann window and its periodogram
    ``|FFT|^2`` taken; the periodograms are averaged and the mean power per
    integer radial frequency ring returned.

    Returns
    -------
    wavelength : ndarray of float, shape (tile // 2,)
        Cells per cycle of each ring ``k = 1 .. tile/2`` (``tile / k``).
    power : ndarray of float, shape (tile // 2,)
        Mean power of the ring, in height units squared.
    """
    h = np.asarray(heights, dtype=np.float64)
    if min(h.shape) < tile:
        raise ValueError(f"grid {h.shape} is smaller than the {tile}-cell tile")
    step = tile // 2

    def starts(n):
        s = list(range(0, n - tile + 1, step))
        return s if s[-1] == n - tile else s + [n - tile]

    window = np.outer(np.hanning(tile), np.hanning(tile))
    total = np.zeros((tile, tile))
    count = 0
    for r in starts(h.shape[0]):
        for c in starts(h.shape[1]):
            t = h[r:r + tile, c:c + tile]
            total += np.abs(np.fft.fft2((t - t.mean()) * window)) ** 2
            count += 1
    mean = total / count
    f = np.fft.fftfreq(tile) * tile
    ring = np.rint(np.hypot(f[:, None], f[None, :])).astype(int)
    k = np.arange(1, tile // 2 + 1)
    power = np.bincount(ring.ravel(), mean.ravel(), minlength=tile)[k] / np.bincount(ring.ravel(), minlength=tile)[k]
    return tile / k, power


def band_powers(heights: np.ndarray, *, bands=OCTAVES, tile: int = 256) -> list[float]:
    """Mean power of :func:`welch_spectrum` over each band (short, long),
    wavelengths in cells, the short end left out and the long end in."""
    wavelength, power = welch_spectrum(heights, tile=tile)
    out = []
    for short, long in bands:
        sel = (wavelength > short) & (wavelength <= long)
        out.append(float(power[sel].mean()) if sel.any() else float("nan"))
    return out


def band_power_ratios(output: np.ndarray, example: np.ndarray, *, bands=OCTAVES, tile: int = 256) -> list[float]:
    """Output's :func:`band_powers` over the example's, per band (1 = the
    example's relief at that scale)."""
    a = band_powers(output, bands=bands, tile=tile)
    b = band_powers(example, bands=bands, tile=tile)
    return [x / y if y > 0 else float("nan") for x, y in zip(a, b)]
