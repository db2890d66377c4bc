"""The output being built: heights, what is filled, and the merge of a patch
(graph-cut seam, then seam removal), paper §5."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..blending.poisson import remove_seam
from .graph_cut import graph_cut_seam


@dataclass(frozen=True, eq=False)
class Cut:
    """Where a new patch goes in its window, and what the seam costs.

    ``normalized_cost`` is the graph-cut cost in units of the example's relief
    per patch side, so it adds to the normalised SSD.
    """

    take_new: np.ndarray
    seam: np.ndarray
    normalized_cost: float


class Canvas:
    """Output arrays and patch merging.

    Parameters
    ----------
    shape : (rows, cols)
    relief : float
        Typical height spread within a patch, metres (cost unit).
    patch_size : int
        Patch side in cells (normalises the seam cost per patch side).
    seam : {"cut", "paste"}, default "cut"
        Graph-cut seam in the overlap, or the new patch pasted over it.
    blend : {"poisson", "c1", "none"}, default "c1"
        Seam removal after each patch (see :func:`~..blending.remove_seam`).
    previous : ndarray of float32, shape (rows, cols), optional
        Local re-synthesis: terrain that is already there ...
    selection : ndarray of bool, shape (rows, cols), optional
        ... and the only cells that may change.  All others are *locked*:
        graph cuts keep them and seam solves hold them fixed.
    """

    def __init__(self, shape: tuple[int, int], relief: float, *, patch_size: int, seam: str = "cut",
                 blend: str = "c1", previous: np.ndarray | None = None, selection: np.ndarray | None = None):
        self.shape = shape
        self.relief = relief
        self.patch_size = patch_size
        self.seam_mode = seam
        self.blend_mode = blend
        if selection is None:
            self.heights = np.zeros(shape, dtype=np.float32)
            self.locked = np.zeros(shape, dtype=bool)
        else:
            self.heights = np.array(previous, dtype=np.float32, copy=True)
            self.locked = ~np.asarray(selection, dtype=bool)
        self.filled = self.locked.copy()
        # Centres of feature patches: later patches must not cut them away.
        self.protected = np.zeros(shape, dtype=bool)
        self.patch_id = np.full(shape, -1, dtype=np.int32)
        self.seams = np.zeros(shape, dtype=bool)
        self._pending = None

    def cut(self, bbox, patch: np.ndarray, *, keep_new: np.ndarray | None = None,
            relief: float | None = None) -> Cut:
        """The seam for ``patch`` in window ``bbox`` (nothing is changed yet).

        ``relief`` (metres) normalises the cost; default the canvas's.
        """
        r0, r1, c0, c1 = bbox
        filled = self.filled[r0:r1, c0:c1]
        locked = self.locked[r0:r1, c0:c1]
        if keep_new is not None:
            keep_new = keep_new & ~locked
        if not filled.any():
            return Cut(np.ones(patch.shape, dtype=bool), np.zeros(patch.shape, dtype=bool), 0.0)
        if self.seam_mode == "paste":
            return Cut(~locked, np.zeros(patch.shape, dtype=bool), 0.0)
        keep_existing = self.protected[r0:r1, c0:c1]
        if keep_new is not None:
            keep_existing = keep_existing & ~keep_new
        res = graph_cut_seam(self.heights[r0:r1, c0:c1], patch, filled,
                             keep_new=keep_new, keep_existing=keep_existing | locked)
        norm = res.cost / (2.0 * (relief or self.relief) * self.patch_size)
        return Cut(res.take_new & ~locked, res.seam, float(norm))

    def place(self, bbox, patch: np.ndarray, cut: Cut, index: int, *, protect: np.ndarray | None = None) -> None:
        """Merge ``patch`` into the output along ``cut`` (then call :meth:`blend`)."""
        r0, r1, c0, c1 = bbox
        take = cut.take_new
        # Remembered for blend(): which cells are new, and whether terrain was
        # there before (in or around the window) to blend with.
        self._pending = (bbox, take, not take.all() or self._touches(bbox))
        win = self.heights[r0:r1, c0:c1]
        win[take] = patch[take]
        # Cells the cut kept were filled already (a stamp may leave some of
        # its window empty).
        self.filled[r0:r1, c0:c1] |= take
        self.patch_id[r0:r1, c0:c1][take] = index
        self.seams[r0:r1, c0:c1] |= cut.seam
        if protect is not None:
            self.protected[r0:r1, c0:c1] |= protect

    def blend(self, bbox) -> None:
        """Remove the seam of the patch last placed in ``bbox`` by a local
        Poisson solve (the canvas's blend mode).

        The solve runs on the window plus a one-cell ring: ring cells that
        hold terrain are its fixed boundary, so the window meets the terrain
        around it without a step; empty ring cells leave the border free.
        """
        placed_bbox, take, has_seam = self._pending
        if tuple(placed_bbox) != tuple(bbox):
            raise RuntimeError("blend() must follow place() for the same window")
        if self.blend_mode != "none" and has_seam:
            self._blend(bbox, take)

    def _touches(self, bbox) -> bool:
        """Whether filled terrain lies just outside the window."""
        R0, R1, C0, C1 = self._ring(bbox)
        ring = self.filled[R0:R1, C0:C1].copy()
        r0, r1, c0, c1 = bbox
        ring[r0 - R0:r1 - R0, c0 - C0:c1 - C0] = False
        return bool(ring.any())

    def _ring(self, bbox):
        r0, r1, c0, c1 = bbox
        rows, cols = self.shape
        return max(r0 - 1, 0), min(r1 + 1, rows), max(c0 - 1, 0), min(c1 + 1, cols)

    def _blend(self, bbox, take: np.ndarray) -> None:
        r0, r1, c0, c1 = bbox
        R0, R1, C0, C1 = self._ring(bbox)
        heights = self.heights[R0:R1, C0:C1]
        inner = np.zeros(heights.shape, dtype=bool)
        inner[r0 - R0:r1 - R0, c0 - C0:c1 - C0] = True
        take_new = np.zeros(heights.shape, dtype=bool)
        take_new[r0 - R0:r1 - R0, c0 - C0:c1 - C0] = take
        filled = self.filled[R0:R1, C0:C1]
        # Locked cells inside the window hold like the ring; empty cells
        # (beside a stamp) take no part.
        fixed = (~inner & filled) | (inner & self.locked[R0:R1, C0:C1])
        solved = remove_seam(heights, take_new, inner & filled, fixed=fixed, mode=self.blend_mode)
        self.heights[r0:r1, c0:c1] = solved[inner].reshape(r1 - r0, c1 - c0)

    def crop(self, box) -> "Canvas":
        """A canvas over ``box`` (r0, r1, c0, c1) of this one, its arrays
        copied: a window can be merged on it elsewhere (another process)
        and the outcome brought back with :meth:`merge`."""
        r0, r1, c0, c1 = box
        out = Canvas.__new__(Canvas)
        out.shape = (r1 - r0, c1 - c0)
        out.relief, out.patch_size = self.relief, self.patch_size
        out.seam_mode, out.blend_mode = self.seam_mode, self.blend_mode
        for name in ("heights", "locked", "filled", "protected", "patch_id", "seams"):
            setattr(out, name, getattr(self, name)[r0:r1, c0:c1].copy())
        out._pending = None
        return out

    def merge(self, crop: "Canvas", box, bbox) -> None:
        """Bring back the patch placed (and blended) on ``crop`` (made by
        :meth:`crop` over ``box``) in window ``bbox`` (this canvas's cells).
        Placing and blending change only the window."""
        r0, r1, c0, c1 = bbox
        win = (slice(r0 - box[0], r1 - box[0]), slice(c0 - box[2], c1 - box[2]))
        for name in ("heights", "filled", "protected", "patch_id", "seams"):
            getattr(self, name)[r0:r1, c0:c1] = getattr(crop, name)[win]

    def finish(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.heights.copy(), self.patch_id.copy(), self.seams.copy()
