"""The feature candidate pool and its cheap ranking (paper §4.1).

For one sketch sample of degree d, every example sample of the same kind and
degree is tried under each of its d cyclic alignments, and under the d
alignments of its mirror image when mirrors are on.  A candidate's
deformation cost is

* the residual of the best rotation that carries the sketch's control points
  onto the candidate's (both relative to their centres, in units of the
  inscribed radius), per control point, plus
* for d >= 3, the thin-plate-spline bending energy (Bookstein 1989) of the map
  between the two point sets, which is what the paper ranks branch points by
  (for d <= 2 the spline is affine and bends nothing).

Rotation itself is free: heights do not care which way a ridge runs, and the
sketch may ask for any direction, so every candidate is turned to the sketch's
direction by the warp.

A painted stroke should become one of the example's main features, not a
minor crest: candidates are also ranked by their *prominence*, how far
above (ridges) or below (valleys) their surroundings within a patch they
stand, as a rank among the pool's samples (:func:`prominence_ranks`); the
least prominent pay :data:`PROMINENCE_WEIGHT` more.  Only candidates that
fit within :data:`PROMINENCE_SLACK` of the best are reordered so.  Mirrors double the pool (paper §4.1.1).  All of it is
batched over candidates with numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..features.samples import FeatureSample, SampleTable
from ..warping.frame import framed_bending_energies

#: Ranking cost of the pool's least prominent sample over its most
#: prominent one, in the deformation cost's units (0.3 against 0.15 on four
#: built-ins x three sketches x two seeds: relief 0.78 -> 0.81 of the
#: example's, strokes' ridges all in the top quarter of heights).
PROMINENCE_WEIGHT = 0.3

#: Candidates deformed more than this beyond the least deformed one rank as
#: least prominent, whatever their prominence.
PROMINENCE_SLACK = 0.03

#: Deformation beyond which a candidate's warp mostly folds or stretches the
#: example over 2x one way (measured on the built-ins' pools): such
#: candidates rank after every one that fits, even after ones the usage
#: rules exclude, since a repeated window is better than a whorl.
FIT_LIMIT = 0.12


@dataclass(frozen=True, eq=False)
class Candidate:
    """One way to use one example sample for one sketch sample.

    Parameters
    ----------
    example : int
        Index of the example DEM.
    center : ndarray (2,)
        Example sample centre ``(row, col)``.
    control : ndarray (d + 1, 2)
        Example control points (absolute), ordered to correspond one to one
        with the sketch sample's control points.
    target : ndarray (d + 1, 2)
        The sketch sample's control points (absolute output coordinates) the
        ``control`` points are to be carried onto.
    mirrored : bool
    deformation : float
        Cost described in the module docstring.
    prominence : float, default 1
        The sample's prominence rank in its pool, 0 (least) to 1 (most); 0
        when it fits more than :data:`PROMINENCE_SLACK` worse than the best.
    """

    example: int
    center: np.ndarray
    control: np.ndarray
    target: np.ndarray
    mirrored: bool
    deformation: float
    prominence: float = 1.0

    @property
    def plainness(self) -> float:
        """The ranking cost of being a minor feature."""
        return PROMINENCE_WEIGHT * (1.0 - self.prominence)


class FeaturePool:
    """Example feature samples of one kind, grouped by degree.

    Parameters
    ----------
    samples : list of (example index, list of FeatureSample)
    radius : float
        Inscribed-circle radius in cells, used to normalise coordinates.
    mirror : bool
        Also offer the mirror image of every sample.
    prominence : list of ndarray of float, optional
        Per entry of ``samples``, each sample's prominence (how far it
        stands above its surroundings for ridges, below for valleys; any
        unit); ranked over the whole pool.  None: every sample counts as most prominent.
    keep : callable, optional
        ``keep(name, make, dtype)`` gives the pool's array ``name``:
        ``make()``'s, or the same stored earlier (the example cache's
        mapped arrays, :func:`~terrasynth_core.exemplars.cache.kept_array`).
    """

    def __init__(self, samples: list[tuple[int, list[FeatureSample]]], radius: float, *, mirror: bool,
                 prominence: list[np.ndarray] | None = None, keep=None):
        self.radius = float(radius)
        self.mirror = mirror
        # The pool's arrays are as large as the library's samples: with
        # ``keep(name, make, dtype)`` (the example cache's mapped arrays)
        # a process holds them as file pages the system can drop.
        self._keep = keep or _made
        if prominence is None:
            ranks = [np.ones(len(lst)) for _, lst in samples]
        else:
            ranks = np.split(prominence_ranks(np.concatenate([np.asarray(p, float) for p in prominence] or [[]])),
                             np.cumsum([len(lst) for _, lst in samples])[:-1])
        # Grouped by degree from the samples' arrays (no object per sample:
        # a library's hundreds of thousands would be made for each pool,
        # and leave the process's small-object memory fragmented).
        tables = [(ex, SampleTable.of(lst, "")) for ex, lst in samples]
        degrees = sorted({int(d) for _, t in tables for d in np.unique(np.asarray(t.degrees))})
        self._groups = {}
        # Per degree: examples, centres, the crossings relative to their
        # centres in radii, prominence ranks; and, made on first use, all
        # the crossings' alignments (:meth:`_alignments`), what every
        # ranking of a sample of that degree starts from (a pool serves
        # every sample of a run, and runs after it).
        self._aligned: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for d in degrees:
            parts = [(ex, *t.of_degree(d), np.asarray(rk, float)[np.asarray(t.degrees) == d])
                     for (ex, t), rk in zip(tables, ranks)]
            parts = [p for p in parts if len(p[1])]
            centers = np.concatenate([p[1] for p in parts])
            group = (
                np.concatenate([np.full(len(p[1]), p[0], dtype=np.int32) for p in parts]),
                centers,
                (np.concatenate([p[2] for p in parts]) - centers[:, None, :]) / self.radius,
                np.concatenate([p[3] for p in parts]),
            )
            self._groups[d] = tuple(self._keep(f"d{d}-{name}", lambda a=a: a, a.dtype.type)
                                    for name, a in zip(("examples", "centers", "crossings", "prominence"), group))

    @property
    def degrees(self) -> list[int]:
        return sorted(self._groups)

    def __getstate__(self) -> dict:
        # Pools are shared by a process's sessions: another thread may add
        # an alignment while this pool is pickled for a worker process, and
        # a dict that changes size mid-pickle fails.  The copy is taken at
        # once (the alignments themselves are never changed).
        state = self.__dict__.copy()
        state["_aligned"] = dict(self._aligned)
        return state

    def size(self, degree: int | None = None) -> int:
        if degree is None:
            return sum(len(g[0]) for g in self._groups.values())
        return len(self._groups.get(degree, ((),))[0])

    def nearest_degree(self, degree: int) -> int | None:
        """The pool's degree closest to ``degree`` (higher wins a tie), or None."""
        if not self._groups:
            return None
        return min(self._groups, key=lambda d: (abs(d - degree), -d))

    def rank(self, sample: FeatureSample, count: int, rng: np.random.Generator, *,
             exclude: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
             crowding: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None) -> list[Candidate]:
        """The ``count`` candidates of least deformation (plus plainness,
        see the module docstring) for ``sample``.

        Uses the pool's nearest degree when the exact one is missing (the
        session reports it).  Ties (e.g. all endpoints cost nothing) are
        broken at random with ``rng`` so seeds give different terrains.

        ``exclude(examples, centres)`` gives a penalty per example sample
        (0 allowed, > 0 excluded; see
        :meth:`~terrasynth_core.matching.usage.UsageRegistry.penalties`):
        the allowed candidates come first, least deformed first, so when
        many are excluded the next-least-deformed allowed ones are ranked
        in their place; excluded ones follow by penalty (least used first),
        so there is always something to place.  Candidates deformed beyond
        :data:`FIT_LIMIT` come after all of them.  ``crowding(examples,
        centres)`` adds a ranking cost per example sample
        (:meth:`~terrasynth_core.matching.usage.UsageRegistry.crowding`).
        """
        degree = self.nearest_degree(sample.degree)
        if degree is None:
            return []
        ex_idx, centers, rel, prominence = self._groups[degree]
        src = (sample.crossings - sample.center) / self.radius  # (d_s, 2)
        if degree == sample.degree:
            if degree not in self._aligned:
                made: list = []

                def aligned(i: int) -> np.ndarray:
                    if not made:  # made once, for the first of the three asked for
                        made.extend(self._alignments(rel))
                    return made[i]

                names = (("flat", np.float64), ("mirrored", np.bool_), ("centred", np.float64))
                self._aligned[degree] = tuple(self._keep(f"d{degree}-{name}", lambda i=i: aligned(i), dtype)
                                              for i, (name, dtype) in enumerate(names))
            flat, mflat, centred = self._aligned[degree]
        else:
            src, rel = _match_counts(src, rel)
            flat, mflat, centred = self._alignments(rel)
        n_align = len(flat) // len(centers)
        cost = _deformations(src, flat, mflat, centred)
        cost = cost + rng.random(cost.shape) * 1e-6  # random tie-break, seeded
        # Prominence reorders only candidates that fit nearly as well as
        # the best: a prominent feature warped far from its shape would be
        # stretched into streaks.
        penalty = np.zeros(cost.shape) if exclude is None else np.repeat(np.asarray(exclude(ex_idx, centers)),
                                                                          n_align)
        # (Measured against the best candidate that may be used.)
        fits = cost <= cost[penalty == penalty.min()].min() + PROMINENCE_SLACK
        standing = np.where(fits, np.repeat(prominence, n_align), 0.0)
        ranked = cost + PROMINENCE_WEIGHT * (1.0 - standing)
        if crowding is not None:
            ranked = ranked + np.repeat(np.asarray(crowding(ex_idx, centers), dtype=float), n_align)
        take = np.lexsort((ranked, penalty, cost > FIT_LIMIT))[:count]
        target = np.vstack([[0.0, 0.0], src]) * self.radius + sample.center
        out = []
        for t in take:
            ci, ai = divmod(int(t), n_align)
            ctrl = np.vstack([[0.0, 0.0], flat[t]]) * self.radius + centers[ci]
            out.append(Candidate(int(ex_idx[ci]), centers[ci].copy(), ctrl, target, bool(mflat[t]), float(cost[t]),
                                 float(standing[t])))
        return out


    def _alignments(self, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every alignment of the pool's crossings: their cyclic shifts,
        and those of the mirrored order when mirrors are on.

        Parameters
        ----------
        rel : ndarray of float, shape (N, d, 2)
            Crossings relative to their centres, in radii.

        Returns
        -------
        flat : ndarray of float, shape (N * a, d, 2)
            Sample by sample, its ``a`` alignments (``a`` = d, or 2d with
            mirrors).
        mirrored : ndarray of bool, shape (N * a,)
        centred : ndarray of float, shape (N * a, d + 1, 2)
            ``flat`` after the centre (0, 0).
        """
        d = rel.shape[1]
        shifts = np.array([np.roll(np.arange(d), -a) for a in range(d)])  # (d, d)
        aligned = rel[:, shifts, :]  # (N, d_align, d, 2)
        mirrored = np.zeros(aligned.shape[:2], dtype=bool)
        if self.mirror:
            mshifts = np.array([np.roll(np.arange(d)[::-1], -a) for a in range(d)])
            maligned = rel[:, mshifts, :]
            aligned = np.concatenate([aligned, maligned], axis=1)
            mirrored = np.concatenate([mirrored, np.ones_like(mirrored)], axis=1)
        flat = aligned.reshape(-1, d, 2)
        centred = np.concatenate([np.zeros((len(flat), 1, 2)), flat], axis=1)
        for a in (flat, mirrored, centred):
            a.flags.writeable = False  # shared by every ranking
        return flat, mirrored.reshape(-1), centred


def _made(name: str, make: Callable[[], np.ndarray], dtype) -> np.ndarray:
    """A pool's array kept as made (no store)."""
    return make()


def prominence_ranks(prominence: np.ndarray) -> np.ndarray:
    """Each value's rank among ``prominence``, 0 (least) to 1 (most); ties
    share their mean rank.

    Parameters
    ----------
    prominence : ndarray of float, shape (N,)

    Returns
    -------
    ndarray of float, shape (N,)
    """
    n = len(prominence)
    if n < 2:
        return np.ones(n)
    order = np.argsort(prominence, kind="stable")
    ranks = np.empty(n)
    ranks[order] = np.arange(n)
    # Ties: the mean rank of their run.
    _, inverse = np.unique(prominence, return_inverse=True)
    ranks = np.bincount(inverse, ranks)[inverse] / np.bincount(inverse)[inverse]
    return ranks / (n - 1)


def _match_counts(src: np.ndarray, rel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Trim the longer of sketch/example crossings to the shorter's count,
    keeping the most evenly spread subset (used only for degree fallback)."""
    ds, de = src.shape[0], rel.shape[1]
    d = min(ds, de)
    if ds > d:
        src = src[np.linspace(0, ds, d, endpoint=False).astype(int)]
    if de > d:
        rel = rel[:, np.linspace(0, de, d, endpoint=False).astype(int)]
    return src, rel


#: Alignments costed at a time: the temporaries of a ranking stay a few
#: megabytes however large the library's pool (each alignment's cost is
#: its own, so the result does not depend on it).
RANK_CHUNK = 1 << 14


def _deformations(src: np.ndarray, flat: np.ndarray, mirrored: np.ndarray, centred: np.ndarray) -> np.ndarray:
    """The deformation cost of carrying ``src`` onto each alignment.

    src : (d, 2); flat : (M, d, 2); mirrored : (M,); centred : (M, d + 1, 2) -> (M,)
    """
    d = src.shape[0]
    framed_src = np.vstack([[0.0, 0.0], src])
    out = np.empty(len(flat))
    for a in range(0, len(flat), RANK_CHUNK):
        part = slice(a, a + RANK_CHUNK)
        cost = _rotation_residual(src, flat[part], mirrored[part]) / (d + 1)
        # The framed spline through the centre (0, 0) and the crossings: it
        # bends as much as the two features' shapes differ.
        out[part] = cost + framed_bending_energies(framed_src, centred[part], mirrored[part])
    return out


def _rotation_residual(src: np.ndarray, dst: np.ndarray, mirrored: np.ndarray) -> np.ndarray:
    """Sum of squared distances after the best rotation of ``src`` onto each
    ``dst`` (about the common centre), reflecting first where ``mirrored``.

    src : (d, 2); dst : (M, d, 2); mirrored : (M,) -> (M,)
    """
    s = np.broadcast_to(src, dst.shape).copy()
    s[mirrored, :, 1] *= -1.0
    dot = np.einsum("mdk,mdk->m", s, dst)
    cross = np.einsum("md,md->m", s[..., 0], dst[..., 1]) - np.einsum("md,md->m", s[..., 1], dst[..., 0])
    total = np.einsum("mdk,mdk->m", s, s) + np.einsum("mdk,mdk->m", dst, dst)
    return np.maximum(total - 2.0 * np.hypot(dot, cross), 0.0)
