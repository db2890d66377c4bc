"""Non-feature fill: the best example windows for a partly filled output
window (paper §4.2).

:class:`FillSearch` (the engine's) finds them through an index of the
example's windows by boundary zone (:mod:`.window_index`): a shortlist of
near neighbours, re-ranked by the exact score below.  Its cost per window
hardly grows with the example's area.  :class:`FftFillSearch` scores every
example position at once by FFT; it is the exhaustive reference the index
is measured against (``benchmarks/bench_fill_search.py``).

The cost of placing example window ``E_p`` (top-left ``p``) over output window
``O`` with filled mask ``m`` is the SSD over the overlap after the best
vertical offset (patches are shifted in height to meet the terrain already
there):

    SSD(p) = sum m (E_p - O)^2 - (sum m (E_p - O))^2 / sum m

Expanded, it needs three correlations of the example with the template
(``E^2 * m``, ``E * mO``, ``E * m``), each an FFT product: O(n log n) for all
positions together.  The search runs on a down-sampled copy of the example
(``coarse_factor``), keeps the k best well-separated positions and refines
each at full resolution.

Windows are *ranked* by that SSD divided by the sum of the two windows'
variances over the overlap (a correlation-like score).  Plain SSD favours
the example's smoothest windows whenever the terrain around is rough (a
smooth window is never far from anything), so a style filled by SSD alone
comes out smoother than its example; the normalised rank removes that
bias.  The SSD itself is still what is returned, for the match cost.  Positions whose window centre holds a strong
example feature are excluded, so fill patches do not add ridges or valleys
the sketch did not ask for.
"""

from __future__ import annotations

import hashlib

import numpy as np
from scipy import fft, ndimage
from skimage.transform import downscale_local_mean

from ..errors import ParamsError
from ..exemplars import cache
from ..heightfield import whole_windows
from .costs import ROUGHNESS_WEIGHT
from .window_index import LazyIndexes, ZoneIndex, zone_of


class _WindowSearch:
    """What both searches share: the windows on offer (on a grid every
    ``coarse_factor`` cells, feature centres excluded), their roughness
    prior, the random first pick and the full-resolution refinement.

    Parameters
    ----------
    example : ndarray of float32, shape (H, W)
        Example heights, no NaN.
    window : (h, w)
        Output window shape to search for (the patch, clipped at borders the
        caller pads to the full patch).
    feature_mask : ndarray of bool, shape (H, W), optional
        Strong features of the example; windows whose central half touches
        one are not offered.
    coarse_factor : int
        Spacing of the windows on offer, cells.
    void_mask : ndarray of bool, shape (H, W), optional
        The example's voids (filled in ``example``): no window touching
        one is offered or refined to.  Where they leave no window on the
        ``coarse_factor`` grid, the grid is made finer until they do.
    """

    def __init__(self, example: np.ndarray, window: tuple[int, int], *, feature_mask=None,
                 coarse_factor: int = 2, void_mask=None):
        self.example = example
        self.window = window
        self._flat = None
        h, w = window
        H, W = example.shape
        self.clear = None  # full-resolution top-left corners whose window has no void; None: all
        f = int(coarse_factor)
        if void_mask is not None and void_mask.any():
            self.clear = _void_free(void_mask, window)
            if not self.clear.any():
                raise ParamsError(f"the example has no {h}x{w} window without nodata")
            # A finer grid where the voids leave no window on this one.
            while f > 1 and not self.clear[::f, ::f].any():
                f -= 1
        self.f = f
        ch, cw = -(-h // f), -(-w // f)
        self.cwin = (ch, cw)
        # Valid coarse top-left positions: the full-resolution window must fit.
        max_r = (H - h) // f
        max_c = (W - w) // f
        allowed = np.ones((max_r + 1, max_c + 1), dtype=bool)
        if self.clear is not None:
            allowed &= self.clear[::f, ::f][: max_r + 1, : max_c + 1]
        if feature_mask is not None and feature_mask.any():
            # A strong feature in the central half of the window rules it out.
            cen = ndimage.uniform_filter(feature_mask.astype(np.float32), size=(max(h // 2, 1), max(w // 2, 1)),
                                         mode="constant")
            # uniform_filter is centred: the value at the window centre.
            rr = np.arange(max_r + 1) * f + h // 2
            cc = np.arange(max_c + 1) * f + w // 2
            near = cen[np.ix_(rr, cc)] > 0
            if (allowed & ~near).sum() >= 16:
                allowed &= ~near
        self.allowed = allowed
        # Float64 grids as large as the example: stored and mapped (a
        # worker of a tiled run with a large library keeps them as file
        # pages, which the system can drop, not as its own memory).
        # The example is hashed once for both grids' keys.
        digest = hashlib.sha1(np.ascontiguousarray(example, dtype=np.float32).tobytes()).hexdigest()
        self._centred_key = f"centred-{_grid_key(digest, example.shape)}"
        self._windows_key = _grid_key(digest, example.shape, window, allowed, f)
        self.prior = cache.kept_array(f"prior-{self._windows_key}", lambda: roughness_prior(example, window, allowed, f),
                                      name="prior", dtype=np.float64)

    def best(self, target: np.ndarray, filled: np.ndarray, count: int, rng: np.random.Generator, *,
             shortlist: np.ndarray | None = None) -> list[tuple[tuple[int, int], float, float]]:
        """The ``count`` best example windows for one output window.

        Parameters
        ----------
        target : ndarray of float, shape ``window``
            Output heights (anything where not filled).
        filled : ndarray of bool, shape ``window``
        count : int
        rng : Generator
            Picks positions at random when nothing is filled yet.
        shortlist : ndarray of int, shape (m, 2), optional
            The windows to score, when the caller has fetched them
            (:meth:`FillSearch.nearest`); else the search fetches them.

        Returns
        -------
        list of ((row, col), ssd, offset, prior)
            Full-resolution top-left corners, the mean squared difference
            over the overlap after the offset, the height offset to add to
            the example window, and the window's roughness prior (see
            :func:`roughness_prior`; weighted by ``ROUGHNESS_WEIGHT`` in the
            ranking).
        """
        n_filled = int(filled.sum())
        if n_filled == 0:
            flat = np.flatnonzero(self.allowed.ravel())
            picks = rng.choice(flat, size=min(count, flat.size), replace=False)
            return [((int(p // self.allowed.shape[1]) * self.f, int(p % self.allowed.shape[1]) * self.f), 0.0, 0.0, 0.0)
                    for p in picks]
        coarse_pos = self._coarse_best(target, filled, count, shortlist)
        out = [self._refine(target, filled, pos) for pos in coarse_pos]
        out.sort(key=lambda t: t[1])
        return out

    def _coarse_best(self, target, filled, count, shortlist=None) -> list[tuple[int, int]]:
        """Up to ``count`` well-separated grid positions (in grid units), best
        first (``shortlist``: the windows to score, for an indexed search)."""
        raise NotImplementedError

    def _separated(self, order, count: int) -> list[tuple[int, int]]:
        """The first ``count`` grid positions of ``order`` (an iterable of
        (row, col), best first) at least a quarter window apart, so the
        candidates differ."""
        ch, cw = self.cwin
        sep = max(1, min(ch, cw) // 4)
        picks = []
        for r, c in order:
            if all(abs(r - pr) > sep or abs(c - pc) > sep for pr, pc in picks):
                picks.append((r, c))
                if len(picks) == count:
                    break
        return picks

    def _refine_radius(self) -> int:
        """How far from a grid pick :meth:`_refine` looks, cells."""
        return self.f - 1

    def _refine(self, target, filled, coarse_rc):
        """The best window within :meth:`_refine_radius` cells of a grid
        pick, by the exact score: ((row, col), ssd, offset, prior)."""
        f = self.f
        h, w = self.window
        H, W = self.example.shape
        d = np.arange(-self._refine_radius(), self._refine_radius() + 1)
        rr, cc = np.meshgrid(coarse_rc[0] * f + d, coarse_rc[1] * f + d, indexing="ij")
        fits = (rr >= 0) & (cc >= 0) & (rr + h <= H) & (cc + w <= W)
        if self.clear is not None:
            fits[fits] = self.clear[rr[fits], cc[fits]]
        positions = np.stack([rr[fits], cc[fits]], axis=1)
        r, c = (int(v) for v in positions[int(np.argmin(self.scores(target, filled, positions)))])
        diff = target[filled].astype(np.float64) - self.example[r:r + h, c:c + w][filled]
        off = diff.mean()
        return (r, c), float(((diff - off) ** 2).mean()), float(off), float(self.prior[r, c])

    def _centred(self) -> np.ndarray:
        """The example minus its mean, float64, flat (made once: moments of
        high terrain lose digits in float32)."""
        if self._flat is None:
            self._flat = cache.kept_array(
                self._centred_key, lambda: (self.example.astype(np.float64) - float(self.example.mean())).ravel(),
                name="centred", dtype=np.float64)
        return self._flat

    def scores(self, target: np.ndarray, filled: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """The exact score of windows, by which the searches rank them.

        Parameters
        ----------
        target : ndarray of float, shape ``window``
        filled : ndarray of bool, shape ``window``, not all False
        positions : ndarray of int, shape (m, 2)
            Top-left corners, cells.

        Returns
        -------
        ndarray of float64, shape (m,)
            Offset-free SSD over the sum of the two windows' variances
            (both over the filled cells) plus ``ROUGHNESS_WEIGHT`` times the
            roughness prior.
        """
        W = self.example.shape[1]
        rows, cols = np.nonzero(filled)
        cells = rows * W + cols
        n = cells.size
        o = target[filled].astype(np.float64)
        o -= o.mean()
        var_o = float(o @ o) / n
        flat = self._centred()
        out = np.empty(positions.shape[0])
        # The offset-free SSD from moments, var(o - e) = var(o) + var(e) -
        # 2 cov(o, e): three passes over the windows' filled cells, all by
        # einsum (BLAS's threads, measured, slowed it 3x on the two cores
        # the synthesis already keeps busy).  In chunks of a few MB.
        chunk = max(1, 500_000 // n)
        for a in range(0, positions.shape[0], chunk):
            p = positions[a:a + chunk]
            e = flat[(p[:, 0] * W + p[:, 1])[:, None] + cells[None, :]]
            mean_e = e.sum(axis=1) / n
            var_e = np.maximum(np.einsum("ij,ij->i", e, e) / n - mean_e**2, 0.0)
            ssd = np.maximum(var_o + var_e - 2.0 * np.einsum("ij,j->i", e, o) / n, 0.0)
            out[a:a + chunk] = ssd / (var_e + var_o + 1e-6) + ROUGHNESS_WEIGHT * self.prior[p[:, 0], p[:, 1]]
        return out


def _void_free(void: np.ndarray, window: tuple[int, int]) -> np.ndarray:
    """Top-left corners whose ``window`` holds no ``void`` cell.

    Returns
    -------
    ndarray of bool, shape (H - h + 1, W - w + 1)
    """
    h, w = window
    H, W = void.shape
    # (The centred windows of whole_windows, shifted to their corners.)
    return whole_windows(~void, window)[h // 2: H - (h - 1) // 2, w // 2: W - (w - 1) // 2]


class FftFillSearch(_WindowSearch):
    """FFT search over one example for one window size: every window on
    offer scored at once (three correlations), O(example area) per query.

    Parameters
    ----------
    example, window, feature_mask, coarse_factor, void_mask
        As for :class:`FillSearch`.
    workers : int
        Threads for the FFTs.
    """

    def __init__(self, example: np.ndarray, window: tuple[int, int], *, feature_mask=None,
                 coarse_factor: int = 2, workers: int = 1, void_mask=None):
        super().__init__(example, window, feature_mask=feature_mask, coarse_factor=coarse_factor,
                         void_mask=void_mask)
        f = self.f
        self.workers = workers
        # The offset-free SSD ignores a constant added to the example, so
        # centring it keeps float32 FFTs accurate (and twice as fast as float64).
        centred = (example - np.float32(example.mean())).astype(np.float32)
        self.coarse = downscale_local_mean(centred, (f, f)).astype(np.float32) if f > 1 else centred
        self.fshape = tuple(fft.next_fast_len(int(s), real=True) for s in self.coarse.shape)
        self.F_e = fft.rfft2(self.coarse, self.fshape, workers=workers)
        self.F_e2 = fft.rfft2(self.coarse**2, self.fshape, workers=workers)

    def _coarse_best(self, target, filled, count, shortlist=None):
        f = self.f
        ch, cw = self.cwin
        h, w = self.window
        m = np.zeros((ch * f, cw * f), dtype=np.float32)
        o = np.zeros((ch * f, cw * f), dtype=np.float32)
        m[:h, :w] = filled
        # Centre the template too (same reason as the example).
        o[:h, :w] = np.where(filled, target - target[filled].mean(), 0.0)
        if f > 1:
            # Per coarse cell: how many filled cells (the weight) and their sum.
            m = m.reshape(ch, f, cw, f).sum(axis=(1, 3))
            o = o.reshape(ch, f, cw, f).sum(axis=(1, 3))
        # Weighted by m, the coarse template value is o / m (the mean of the
        # filled cells), so m * template = o and m * template^2 = o^2 / m.
        F_m = fft.rfft2(m, self.fshape, workers=self.workers)
        F_mo = fft.rfft2(o, self.fshape, workers=self.workers)
        ar, ac = self.allowed.shape
        sum_m = m.sum()
        sum_mo = o.sum()
        with np.errstate(invalid="ignore", divide="ignore"):
            sum_mo2 = np.where(m > 0, o**2 / np.where(m > 0, m, 1.0), 0.0).sum()
        # Circular cross-correlations (no wrap-around for positions that fit);
        # the two terms linear in the spectra share one inverse transform.
        conj_m = np.conj(F_m)
        s_e2m = fft.irfft2(self.F_e2 * conj_m, self.fshape, workers=self.workers)[:ar, :ac]
        s_emo = fft.irfft2(self.F_e * np.conj(F_mo), self.fshape, workers=self.workers)[:ar, :ac]
        s_em = fft.irfft2(self.F_e * conj_m, self.fshape, workers=self.workers)[:ar, :ac]
        ssd = s_e2m - 2.0 * s_emo + sum_mo2 - (s_em - sum_mo) ** 2 / sum_m
        # Ranked by SSD over the two windows' variances (see the module notes).
        var_c = s_e2m - s_em**2 / sum_m
        var_t = sum_mo2 - sum_mo**2 / sum_m
        ssd = ssd / (np.maximum(var_c, 0.0) + var_t + 1e-6 * sum_m)
        ssd = ssd + ROUGHNESS_WEIGHT * self.prior[::f, ::f][:ar, :ac]
        ssd[~self.allowed] = np.inf
        # k best, at least a quarter window apart so they differ.
        flat = ssd.ravel()
        n_look = min(max(count * 50, 200), flat.size)
        head = np.argpartition(flat, n_look - 1)[:n_look]
        order = head[np.argsort(flat[head], kind="stable")]
        order = order[np.isfinite(flat[order])]
        return self._separated((divmod(int(i), ac) for i in order), count)



class FillSearch(_WindowSearch):
    """Indexed search over one example for one window size (Liang et al.
    2001): a shortlist from the zone index of the window's filled strips,
    re-ranked by the exact score on the true filled mask.

    Parameters
    ----------
    example : ndarray of float32, shape (H, W)
        Example heights, no NaN.
    window : (h, w)
        Output window shape to search for.
    feature_mask : ndarray of bool, shape (H, W), optional
        Strong features of the example; windows whose central half touches
        one are not offered.
    coarse_factor : int
        Spacing of the indexed windows, cells; the best are refined to the
        cell around them.
    overlap : int, optional
        Width of the boundary strips, cells; default a third of the window.
    shortlist : int
        Windows fetched from the index and scored exactly.
    use_cache : bool
        Load zone indexes from (and save them to) the example-analysis
        disk cache.
    void_mask : ndarray of bool, shape (H, W), optional
        The example's voids: no window touching one is offered.

    References
    ----------
    Liang, L., Liu, C., Xu, Y.-Q., Guo, B., Shum, H.-Y. (2001). Real-time
    texture synthesis by patch-based sampling. ACM TOG 20(3).
    """

    #: Below this many windows on offer, all are scored exactly (an index
    #: would cost more than it saves).
    EXHAUSTIVE_BELOW = 4096

    def __init__(self, example: np.ndarray, window: tuple[int, int], *, feature_mask=None,
                 coarse_factor: int = 2, overlap: int | None = None, shortlist: int = 96,
                 use_cache: bool = True, void_mask=None):
        super().__init__(example, window, feature_mask=feature_mask, coarse_factor=coarse_factor,
                         void_mask=void_mask)
        self.overlap = int(overlap) if overlap else max(2, min(window) // 3)
        self.shortlist = int(shortlist)
        # The windows on offer and their priors, stored and mapped as the
        # prior's grid (a library's worth would otherwise be a worker's own).
        self.positions = cache.kept_array(f"positions-{self._windows_key}",
                                          lambda: np.argwhere(self.allowed) * self.f, name="positions", dtype=np.int32)
        self.indexes = None
        if self.positions.shape[0] >= self.EXHAUSTIVE_BELOW:
            load, save = (_load_index, _save_index) if use_cache else (None, None)
            prior = cache.kept_array(f"prior-at-{self._windows_key}",
                                     lambda: self.prior[self.positions[:, 0], self.positions[:, 1]],
                                     name="prior", dtype=np.float64)
            self.indexes = LazyIndexes(example, window, self.overlap, self.positions, prior, load=load, save=save)

    def candidates(self, target: np.ndarray, filled: np.ndarray) -> np.ndarray:
        """The windows scored exactly for this output window.

        Returns
        -------
        ndarray of int32, shape (m, 2)
            Top-left corners (on the grid): the index's shortlist, or every
            window on offer for a small example.
        """
        found = self.nearest(target, filled)
        return self.positions if found is None else found

    def nearest(self, target: np.ndarray, filled: np.ndarray) -> np.ndarray | None:
        """The index's shortlist for this output window (``filled`` not
        empty: a window with nothing in it has no zone to match); None for
        a small example scored whole."""
        zone = self.zone_index(filled)
        return None if zone is None else zone.query(target, filled, self.shortlist)

    def make_indexes(self, cancel=None) -> None:
        """Make every zone's index now (none for a small example scored
        whole): a whole-map run asks for the zones its windows make, a live
        stroke's crop, filling holes in kept terrain, for others, built in
        the stroke's time (0.3-0.4 s each for a 1201x1201 example) unless
        made beforehand.  ``cancel`` as for
        :meth:`~.window_index.LazyIndexes.make_all`."""
        if self.indexes is not None:
            self.indexes.make_all(cancel)

    def zone_index(self, filled: np.ndarray) -> ZoneIndex | None:
        """The index of the zone ``filled`` makes (not empty); None for a
        small example scored whole."""
        return None if self.indexes is None else self.indexes.get(zone_of(filled, self.overlap))

    def _refine_radius(self) -> int:
        # The grid windows are scored exactly at full resolution, so a pick
        # is refined over the cells nearer to it than to any other grid
        # window; the FFT search scores block means and looks further.
        return self.f // 2

    def _coarse_best(self, target, filled, count, shortlist=None):
        positions = self.candidates(target, filled) if shortlist is None else shortlist
        score = self.scores(target, filled, positions)
        order = np.argsort(score, kind="stable")
        return self._separated(((int(r) // self.f, int(c) // self.f) for r, c in positions[order]), count)


#: Version of the stored search grids (:func:`~terrasynth_core.exemplars.cache.kept_array`): raised when what
#: they hold changes.
GRIDS_VERSION = 1


def _grid_key(digest: str, shape: tuple[int, int], window: tuple[int, int] | None = None,
              allowed: np.ndarray | None = None, f: int = 0) -> str:
    """Digest of what a search's stored grid is made of: the example (its
    bytes' SHA-1 ``digest``) and, for the prior, the window, the windows on
    offer and their spacing."""
    h = hashlib.sha1(digest.encode())
    if allowed is not None:
        h.update(np.ascontiguousarray(allowed, dtype=bool).tobytes())
    h.update(repr((tuple(shape), None if window is None else tuple(window), int(f), GRIDS_VERSION)).encode())
    return h.hexdigest()


def _load_index(key: str) -> ZoneIndex | None:
    arrays = cache.load_arrays(key)
    if arrays is None:
        return None
    try:
        return ZoneIndex.from_arrays(arrays)
    except Exception:  # a damaged or foreign index: rebuild it
        return None


def _save_index(key: str, index: ZoneIndex) -> None:
    cache.save_arrays(key, index.to_arrays())


def roughness_prior(example: np.ndarray, window: tuple[int, int], allowed: np.ndarray, f: int) -> np.ndarray:
    """How far each window's roughness is from the example's typical window.

    Matching the overlap alone favours smooth windows (their few details
    are easy to agree with), so a region grown from overlaps comes out
    smoother than its example (measured: the chosen windows' median slope
    7-11 % below that of all windows).  This prior, ``ln(rho / rho_50)**2``
    with ``rho`` a window's mean gradient magnitude and ``rho_50`` its
    median over the windows on offer, makes a window pay for straying from
    the example's typical roughness in either direction.

    Parameters
    ----------
    example : ndarray of float32, shape (H, W)
    window : (h, w)
    allowed : ndarray of bool, shape (ar, ac)
        Windows on offer, at the coarse positions (every ``f`` cells).
    f : int
        Coarse factor.

    Returns
    -------
    ndarray of float64, shape (H - h + 1, W - w + 1)
        The prior per full-resolution top-left corner (0 at the median).
    """
    h, w = window
    gr, gc = np.gradient(example.astype(np.float64))
    grad = np.hypot(gr, gc)
    # Window means from a summed-area table: exact, O(1) per window.
    sat = np.pad(grad.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    total = sat[h:, w:] - sat[:-h, w:] - sat[h:, :-w] + sat[:-h, :-w]
    rho = total / (h * w) + 1e-9
    offered = rho[::f, ::f][:allowed.shape[0], :allowed.shape[1]][allowed]
    typical = float(np.median(offered)) if offered.size else float(np.median(rho))
    return np.log(rho / typical) ** 2
