"""Undo and redo of document edits: one stroke is one step.

A sketch edit records only the layers it changed and only the window it
touched, as ``(bbox, old, new)`` (napari's Labels layer does the same), so a
long history of small strokes on a large sketch stays small.  Edits of the
document outside the layers (a style removed, pins and stamps following a
resized sketch) are :class:`DocumentEdit` s in the same history, so Ctrl+Z
undoes them in order with the strokes; a step may hold several edits (a
resize and the pins it moved are one step).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Union

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


@dataclass(frozen=True, eq=False)
class DocumentEdit:
    """One undoable change of the document outside the sketch layers.

    Parameters
    ----------
    undo : callable()
        Puts the document back as it was before the change.
    redo : callable()
        Makes the change again.
    """

    undo: Callable[[], None]
    redo: Callable[[], None]

    @property
    def nbytes(self) -> int:
        return 0


Edit = Union[SketchEdit, DocumentEdit]


class SketchHistory:
    """A linear undo/redo stack of steps, each a list of :class:`SketchEdit`
    and :class:`DocumentEdit` applied in order (undone in reverse).

    Parameters
    ----------
    max_bytes : int, default 256 MiB
        Oldest steps are dropped once the stored windows exceed this.
    """

    def __init__(self, *, max_bytes: int = 256 * 2**20) -> None:
        self._edits: list[list[Edit]] = []
        self._index = 0  # edits[:index] are done, edits[index:] undone
        self._max_bytes = max_bytes

    @property
    def can_undo(self) -> bool:
        return self._index > 0

    @property
    def can_redo(self) -> bool:
        return self._index < len(self._edits)

    def push(self, edit: Edit) -> None:
        """Record a new step of one edit; the undone steps after the current one are dropped."""
        del self._edits[self._index:]
        self._edits.append([edit])
        self._trim()

    def join(self, edit: Edit) -> None:
        """Add ``edit`` to the last step done (a consequence of it, undone with
        it); a new step when there is none."""
        if self._index == 0 or self._index != len(self._edits):
            self.push(edit)
            return
        self._edits[-1].append(edit)
        self._trim()

    def _trim(self) -> None:
        total = sum(_step_bytes(step) for step in self._edits)
        while total > self._max_bytes and len(self._edits) > 1:
            total -= _step_bytes(self._edits.pop(0))
        self._index = len(self._edits)

    def undo(self) -> list[Edit] | None:
        """The step to revert (its edits in the order they were made), or
        None when there is nothing to undo."""
        if not self.can_undo:
            return None
        self._index -= 1
        return self._edits[self._index]

    def redo(self) -> list[Edit] | None:
        """The step to apply again, or None when there is nothing to redo."""
        if not self.can_redo:
            return None
        self._index += 1
        return self._edits[self._index - 1]

    def clear(self) -> None:
        self._edits.clear()
        self._index = 0


def _step_bytes(step: list[Edit]) -> int:
    return sum(edit.nbytes for edit in step)
