"""Which example windows a run has used for its feature patches, so that no
window is copied over and over (issue 10, "Variety").

Ranking feature candidates by deformation alone is deterministic: the
straightest example path wins every straight stroke, and a ring valley
becomes one cross-section repeated all the way round.  The registry records
the source (example, sample centre) and the output window of every feature
patch placed, and answers, for candidate sources of a new patch:

* how many feature patches one example window would supply if the candidate
  were taken (a window is a disc of :data:`SAME_WINDOW` cells around a
  source, in one example); a candidate that would bring any window above the
  run's cap (:func:`window_cap`) is excluded;
* whether a neighbouring feature patch (overlapping output window, or centre
  within a patch size) already uses the candidate's window; such candidates
  are excluded too;
* whether a feature patch a little further (centre within
  :data:`NEAR_REACH` patch sizes) uses it: such candidates pay a ranking
  cost (:meth:`UsageRegistry.crowding`).

:func:`source_reuse` is the measure the cap bounds, the one figure tests,
reports and benchmarks use.
"""

from __future__ import annotations

import math
from typing import Callable, Iterable

import numpy as np

from ..exemplars.patch_size import SAME_WINDOW

#: Largest share of a run's feature patches one window may supply ...
MAX_SHARE = 0.10
#: ... when the pool has at least this many samples of the kind (samples,
#: not the distinct windows the automatic patch size counts).
MIN_POOL = 20
#: Patch kinds that are feature patches.
FEATURE_KINDS = ("branch", "end", "path")
#: Feature patches centred within this many patch sizes of one another
#: should not share an example window either.  Along a stroke patches
#: stand about half a patch apart, so excluding a patch's neighbours alone
#: let two sources alternate down a straight stroke, the same cross-section
#: every other patch, which reads as made: half the feature patches of the
#: shared sketches on the built-ins had such a repeat within two patch
#: sizes (St. Helens' 77-85 %).
NEAR_REACH = 2.0
#: The ranking cost of a window a near patch uses (:data:`NEAR_REACH`):
#: that of being the pool's least prominent feature
#: (:data:`~terrasynth_core.matching.candidates.PROMINENCE_WEIGHT`), so a
#: window that fits much better may still be taken.  Ranked after every
#: free window instead, small pools gave up their main features: St.
#: Helens' power at 16-64 cells fell to 0.4-0.5 of the example's.
NEAR_WEIGHT = 0.3


def window_cap(n_features: int, n_kind: int, pool_size: int) -> int:
    """Most feature patches one example window may supply in a run.

    Parameters
    ----------
    n_features : int
        Feature samples of the run (all kinds).
    n_kind : int
        Feature samples of the run of the pool's kind.
    pool_size : int
        Example samples of that kind in the pool.

    Returns
    -------
    int
        ``max(1, floor(MAX_SHARE * n_features))``; with a pool smaller than
        :data:`MIN_POOL`, at least the even share ``ceil(n_kind / pool_size)``.
    """
    cap = max(1, math.floor(MAX_SHARE * n_features))
    if 0 < pool_size < MIN_POOL:
        cap = max(cap, math.ceil(n_kind / pool_size))
    return cap


def source_reuse(records: Iterable, *, same_window: float = SAME_WINDOW) -> float:
    """Largest share of the feature patches whose sources lie in one example
    window (within ``same_window`` cells of one of them, same example).

    Parameters
    ----------
    records : iterable of PatchRecord
        Anything with ``kind``, ``example`` and ``source``; only feature
        patches (branch, end, path) count.

    Returns
    -------
    float
        0 without feature patches; 1/n when no two share a window.
    """
    feats = [r for r in records if r.kind in FEATURE_KINDS]
    if not feats:
        return 0.0
    examples = np.array([r.example for r in feats])
    centres = np.array([r.source for r in feats], dtype=float)
    near = _near(examples, centres, examples, centres, same_window)
    return float(near.sum(axis=1).max()) / len(feats)


def _near(ex_a, c_a, ex_b, c_b, radius: float) -> np.ndarray:
    """(len(a), len(b)) bool: same example and within ``radius`` cells."""
    d2 = ((c_a[:, None, :] - c_b[None, :, :]) ** 2).sum(axis=-1)
    return (ex_a[:, None] == ex_b[None, :]) & (d2 <= radius * radius)


class UsageRegistry:
    """The feature patches placed so far: source and output window.

    Parameters
    ----------
    patch_size : int
        Output centres closer than this are neighbours.
    same_window : float
        Cells within which two sources of one example share a window.
    """

    def __init__(self, patch_size: int, *, same_window: float = SAME_WINDOW):
        self.patch_size = int(patch_size)
        self.same_window = float(same_window)
        self._examples: list[int] = []
        self._sources: list[tuple[float, float]] = []
        self._boxes: list[tuple[int, int, int, int]] = []
        self._centres: list[tuple[float, float]] = []
        # Per recorded source, how many recorded sources share its window
        # (itself included), kept as they come: counted afresh from all
        # pairs for every candidate ranking, a sketch of a thousand strokes
        # spent minutes there (the pairs grow with the square of the
        # patches, the rankings with their number).
        self._own: list[int] = []

    def __len__(self) -> int:
        return len(self._examples)

    def record(self, example: int, source, bbox, centre) -> None:
        """A feature patch from ``example`` at ``source`` (row, col) was
        placed on the output window ``bbox`` around ``centre``."""
        shared = _near(np.array([int(example)]), np.array([source], dtype=float).reshape(1, 2),
                       np.array(self._examples, dtype=np.int64),
                       np.array(self._sources, dtype=float).reshape(-1, 2), self.same_window)[0]
        for i in np.flatnonzero(shared):
            self._own[i] += 1
        self._own.append(1 + int(shared.sum()))
        self._examples.append(int(example))
        self._sources.append((float(source[0]), float(source[1])))
        self._boxes.append(tuple(int(v) for v in bbox))
        self._centres.append((float(centre[0]), float(centre[1])))

    def snapshot(self) -> "UsageRegistry":
        """A copy that later :meth:`record` calls do not change (for work
        prepared on another thread or process: what it sees must not depend
        on timing)."""
        out = UsageRegistry(self.patch_size, same_window=self.same_window)
        out._examples = list(self._examples)
        out._sources = list(self._sources)
        out._boxes = list(self._boxes)
        out._centres = list(self._centres)
        out._own = list(self._own)
        return out

    def _arrays(self):
        return (np.array(self._examples, dtype=np.int64),
                np.array(self._sources, dtype=float).reshape(-1, 2),
                np.array(self._boxes, dtype=np.int64).reshape(-1, 4),
                np.array(self._centres, dtype=float).reshape(-1, 2))

    def uses(self, examples: np.ndarray, sources: np.ndarray) -> np.ndarray:
        """Per candidate source, the most feature patches any one window
        would supply if it were taken (itself included): 1 for a fresh
        window."""
        examples = np.asarray(examples, dtype=np.int64)
        sources = np.asarray(sources, dtype=float).reshape(-1, 2)
        if not self._examples:
            return np.ones(len(examples), dtype=np.int64)
        ex, src, _, _ = self._arrays()
        near = _near(examples, sources, ex, src, self.same_window)  # (N, M)
        # Each used source's window as it stands (itself included).
        own = np.array(self._own, dtype=np.int64)  # (M,)
        load = near.sum(axis=1) + 1
        grown = np.where(near, own[None, :] + 1, 0).max(axis=1)
        return np.maximum(load, grown)

    def neighbour_shares(self, examples: np.ndarray, sources: np.ndarray, bbox, centre, *,
                         reach: float = 1.0) -> np.ndarray:
        """Per candidate source, whether a feature patch neighbouring the
        output window ``bbox`` (overlapping it, or centred within ``reach``
        patch sizes of ``centre``) already uses its window."""
        examples = np.asarray(examples, dtype=np.int64)
        sources = np.asarray(sources, dtype=float).reshape(-1, 2)
        if not self._examples:
            return np.zeros(len(examples), dtype=bool)
        ex, src, boxes, centres = self._arrays()
        r0, r1, c0, c1 = bbox
        overlap = (boxes[:, 0] < r1) & (boxes[:, 1] > r0) & (boxes[:, 2] < c1) & (boxes[:, 3] > c0)
        close = ((centres - np.asarray(centre, dtype=float)) ** 2).sum(axis=1) < (reach * self.patch_size) ** 2
        neighbour = overlap | close
        if not neighbour.any():
            return np.zeros(len(examples), dtype=bool)
        return _near(examples, sources, ex[neighbour], src[neighbour], self.same_window).any(axis=1)

    def penalties(self, examples: np.ndarray, sources: np.ndarray, bbox, centre, cap: int) -> np.ndarray:
        """0 for an allowed candidate source; for an excluded one (its window
        shared with a neighbour, or over ``cap``) 1 + the uses it would give
        its window, so the least used comes first when all are excluded."""
        uses = self.uses(examples, sources)
        excluded = (uses > cap) | self.neighbour_shares(examples, sources, bbox, centre)
        return np.where(excluded, 1 + uses, 0)

    def crowding(self, examples: np.ndarray, sources: np.ndarray, bbox, centre) -> np.ndarray:
        """Per candidate source, the ranking cost :data:`NEAR_WEIGHT` when a
        feature patch centred within :data:`NEAR_REACH` patch sizes of
        ``centre`` (or overlapping ``bbox``) uses its window, else 0."""
        near = self.neighbour_shares(examples, sources, bbox, centre, reach=NEAR_REACH)
        return np.where(near, NEAR_WEIGHT, 0.0)

    def exclusion(self, bbox, centre, cap: int) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """:meth:`penalties` for one output window, as the ``exclude`` input
        of :meth:`FeaturePool.rank <terrasynth_core.matching.candidates.FeaturePool.rank>`."""
        return lambda examples, sources: self.penalties(examples, sources, bbox, centre, cap)

    def crowding_of(self, bbox, centre) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
        """:meth:`crowding` for one output window, as the ``crowding`` input
        of :meth:`FeaturePool.rank <terrasynth_core.matching.candidates.FeaturePool.rank>`."""
        return lambda examples, sources: self.crowding(examples, sources, bbox, centre)
