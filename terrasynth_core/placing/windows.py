"""Where patches go: the window of a feature patch, the grid of fill windows
and the order they are filled in (paper §4.2)."""

from __future__ import annotations

import numpy as np

Box = tuple[int, int, int, int]


def patch_window(center, patch_size: int, shape: tuple[int, int]) -> Box:
    """The window ``(r0, r1, c0, c1)`` of a patch centred on ``center``,
    clipped to an output of ``shape`` (so it may be smaller at the edges)."""
    r0 = int(round(center[0] - patch_size / 2))
    c0 = int(round(center[1] - patch_size / 2))
    rows, cols = shape
    return max(r0, 0), min(r0 + patch_size, rows), max(c0, 0), min(c0 + patch_size, cols)


def fill_windows(filled: np.ndarray, patch_size: int, *, overlap: int) -> list[Box]:
    """A grid of patch windows overlapping by ``overlap`` cells, the last row
    and column flush with the output's edge, minus those already full.

    Parameters
    ----------
    filled : ndarray of bool, shape (rows, cols)
        Cells that hold terrain.
    patch_size : int
    overlap : int
        Cells shared by neighbouring windows.

    Returns
    -------
    list of (r0, r1, c0, c1)
        Row by row, top-left first.
    """
    step = patch_size - overlap
    rows, cols = filled.shape
    rs = np.unique(np.r_[np.arange(0, rows - patch_size, step), rows - patch_size])
    cs = np.unique(np.r_[np.arange(0, cols - patch_size, step), cols - patch_size])
    out = []
    for r in rs:
        for c in cs:
            if not filled[r:r + patch_size, c:c + patch_size].all():
                out.append((int(r), int(r + patch_size), int(c), int(c + patch_size)))
    return out


def estimate_fill_count(shape: tuple[int, int], patch_size: int, *, overlap: int, n_features: int,
                        selection: np.ndarray | None = None) -> int:
    """About how many fill patches a run will place, for progress reports.

    The full grid of fill windows, scaled by the selected share for a local
    re-synthesis, minus half the feature patches (each covers about half a
    window's worth of the grid).
    """
    step = patch_size - overlap
    rows, cols = shape
    n = (-(-(rows - patch_size) // step) + 1) * (-(-(cols - patch_size) // step) + 1)
    if selection is not None:
        n = int(np.ceil(n * selection.mean())) + 4
    return max(n - n_features // 2, 0)


def region_seeds(group_map: np.ndarray, filled: np.ndarray, windows: list[Box]) -> list[tuple[int, Box]]:
    """For each region with no terrain yet (when there is more than one),
    the empty window most inside it, nearest its centre.

    Parameters
    ----------
    group_map : ndarray of int, shape (rows, cols)
        Region (style group) per cell.
    filled : ndarray of bool, shape (rows, cols)
    windows : list of (r0, r1, c0, c1)
        Candidate windows, in order (the first wins a tie).

    Returns
    -------
    list of (group, window)
        In increasing group order; only windows more than half inside
        their region.
    """
    present = np.unique(group_map)
    if present.size < 2:
        return []
    out = []
    for g in (int(v) for v in present):
        region = group_map == g
        if (filled & region).any():
            continue
        centre = np.argwhere(region).mean(axis=0)
        best = None
        for bbox in windows:
            r0, r1, c0, c1 = bbox
            if filled[r0:r1, c0:c1].any():
                continue
            share = region[r0:r1, c0:c1].mean()
            dist = np.hypot((r0 + r1) / 2 - centre[0], (c0 + c1) / 2 - centre[1])
            key = (-share, dist)
            if best is None or key < best[0]:
                best = (key, bbox)
        if best is not None and best[0][0] < -0.5:
            out.append((g, best[1]))
    return out


class WindowQueue:
    """Fill windows, most constrained first: the one with the largest filled
    share, so fill grows out from the placed features (top-left first among
    equals).  Shares are updated only for windows a placed patch touches.

    With ``defer_shared``, a window whose empty cells all lie in other
    windows of the grid as well comes after every window with an empty cell
    of its own: by its turn those have filled its cells, and it is dropped.
    Taken first (as the most filled), such windows each placed a patch for
    a sliver of cells: in a local re-synthesis, the slivers of selection
    the kept terrain leaves in the windows along the selection's edge (a
    live stroke: 26-38 fill patches, 10-20 with it).  A deferred window still
    holding empty cells at its turn (they lay only in other deferred ones)
    is filled then, in a wave of its own.

    Parameters
    ----------
    windows : list of (r0, r1, c0, c1)
    filled : ndarray of bool, shape (rows, cols)
        The output's filled mask, read live (not copied).
    defer_shared : bool, default False
    """

    def __init__(self, windows: list[Box], filled: np.ndarray, *, defer_shared: bool = False):
        self.filled = filled
        self.boxes = np.array(windows, dtype=np.int64).reshape(-1, 4)
        self.share = np.array([filled[r0:r1, c0:c1].mean() for r0, r1, c0, c1 in self.boxes])
        self.done = np.zeros(len(self.boxes), dtype=bool)
        self._index = {tuple(int(v) for v in box): i for i, box in enumerate(self.boxes)}
        # Subtracted from the share to rank a window: 2 for a deferred one
        # (see above), 0 for the others, which rank by their share exactly.
        self.offset = np.zeros(len(self.boxes))
        if defer_shared:
            count = np.zeros(filled.shape, np.int32)
            for r0, r1, c0, c1 in self.boxes:
                count[r0:r1, c0:c1] += 1
            for i, (r0, r1, c0, c1) in enumerate(self.boxes):
                if not ((count[r0:r1, c0:c1] == 1) & ~filled[r0:r1, c0:c1]).any():
                    self.offset[i] = 2.0

    def update(self, bbox: Box) -> None:
        """Refresh the filled share of the windows ``bbox`` overlaps."""
        r0, r1, c0, c1 = bbox
        b = self.boxes
        touched = ~self.done & (b[:, 0] < r1) & (b[:, 1] > r0) & (b[:, 2] < c1) & (b[:, 3] > c0)
        for i in np.flatnonzero(touched):
            w0, w1, v0, v1 = b[i]
            self.share[i] = self.filled[w0:w1, v0:v1].mean()

    def pop_wave(self, size: int, *, share: float = 0.5) -> list[Box]:
        """Up to ``size`` windows that can be filled at the same time: the
        next one (as :meth:`pop`), then the most constrained others whose
        window plus a one-cell ring (what placing and blending a window
        reads) does not touch a window already taken, and that are at least
        ``share`` as filled as the first.  Empty when none is left.

        The wave depends only on the filled mask, never on how many
        processes work on it, so a run gives the same bytes with any number.
        """
        first = self.pop()
        if first is None:
            return []
        wave = [first]
        rank = self.share - self.offset
        floor = share * rank[self._index[first]]
        b = self.boxes
        for i in np.lexsort((np.arange(len(b)), -rank)):
            if len(wave) == size or rank[i] <= max(floor, 0.0):
                break
            if self.done[i] or self.share[i] >= 1.0:
                continue
            w0, w1, v0, v1 = b[i]
            if any(w0 - 1 < r1 and w1 + 1 > r0 and v0 - 1 < c1 and v1 + 1 > c0 for r0, r1, c0, c1 in wave):
                continue
            self.done[i] = True
            wave.append(tuple(int(v) for v in b[i]))
        return wave

    def pop(self) -> Box | None:
        """The next window not yet full, or None; windows filled in the
        meantime are dropped."""
        while not self.done.all():
            i = int(np.argmax(np.where(self.done, -np.inf, self.share - self.offset)))
            self.done[i] = True
            if self.share[i] < 1.0:
                return tuple(int(v) for v in self.boxes[i])
        return None
