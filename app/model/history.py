"""Undo and redo of sketch edits: one stroke is one step.

An edit records only the layers it changed and only the window it touched,
as ``(bbox, old, new)`` (napari's Labels layer does the same), so a long
history of small strokes on a large sketch stays small.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Half-open window ``(r0, r1, c0, c1)`` in sketch cells.
BBox = tuple[int, int, int, int]


@dataclass(frozen=True, eq=False)
class SketchEdit:
    """One undoable change of some sketch layers.

    Parameters
    ----------
    bbox : (r0, r1, c0, c1) or None
        Window the edit changed; ``None`` when whole layers were replaced
        (their shape may have changed too).
    old : dict of str -> ndarray
        Contents before the edit of each layer it changed (``"ridge"``,
        ``"valley"``, ``"style"``, ``"water"``), shape of ``bbox`` (or whole
        layers).
    new : dict of str -> ndarray
        Contents after the edit, same keys.
    """

    bbox: BBox | None
    old: dict[str, np.ndarray]
    new: dict[str, np.ndarray]

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in self.old.values()) + sum(a.nbytes for a in self.new.values())


class SketchHistory:
    """A linear undo/redo stack of :class:`SketchEdit`.

    Parameters
    ----------
    max_bytes : int, default 256 MiB
        Oldest steps are dropped once the stored windows exceed this.
    """

    def __init__(self, *, max_bytes: int = 256 * 2**20) -> None:
        self._edits: list[SketchEdit] = []
        self._index = 0  # edits[:index] are done, edits[index:] undone
        self._max_bytes = max_bytes

    @property
    def can_undo(self) -> bool:
        return self._index > 0

    @property
    def can_redo(self) -> bool:
        return self._index < len(self._edits)

    def push(self, edit: SketchEdit) -> None:
        """Record a new edit; the undone steps after the current one are dropped."""
        del self._edits[self._index:]
        self._edits.append(edit)
        total = sum(e.nbytes for e in self._edits)
        while total > self._max_bytes and len(self._edits) > 1:
            total -= self._edits.pop(0).nbytes
        self._index = len(self._edits)

    def undo(self) -> SketchEdit | None:
        """The edit to revert, or None when there is nothing to undo."""
        if not self.can_undo:
            return None
        self._index -= 1
        return self._edits[self._index]

    def redo(self) -> SketchEdit | None:
        """The edit to apply again, or None when there is nothing to redo."""
        if not self.can_redo:
            return None
        self._index += 1
        return self._edits[self._index - 1]

    def clear(self) -> None:
        self._edits.clear()
        self._index = 0
