"""Fill windows on both cores: independent windows merged in parallel
processes, the same bytes whatever their number.

A fill window reads only itself and the one-cell ring around it (search
target, graph cut, seam solve) and writes only itself.  The fill takes its
windows in *waves* (:meth:`~..placing.windows.WindowQueue.pop_wave`) of
windows that do not read each other's cells; each window of a wave is
searched, cut, placed and blended on a copy of its neighbourhood
(:meth:`~..placing.canvas.Canvas.crop`), here or in a worker process, and
merged back in wave order.  Which process did the work changes nothing.

The workers are the run's (:mod:`.workers`); what a run's windows need
from the examples (their detail and fill searches) goes to them once, as a
kit file they load on their first window of the run.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..exemplars.mapped_pages import keep_within_budget
from ..placing.canvas import Canvas
from .fill_patches import choose_fill, search_fill
from .result import PatchRecord
from .workers import KitWorkers

#: Windows per wave; fixed (not the process count) so the result does not
#: depend on how many processes fill them.
WAVE = 4

#: Fewest fill windows worth starting worker processes for; a shorter
#: fill (a live stroke's crop) uses them only when they are up and warm
#: already (the result is the same either way).
MIN_PARALLEL_WINDOWS = 64


@dataclass(frozen=True, eq=False)
class FillKit:
    """What every fill window of a run needs from the examples.

    Parameters
    ----------
    searches : list of FillSearch or None
        Per example.
    detail : list of ndarray of float32
        Each example's detail heights, metres.
    anchor : ndarray of float, shape (n_examples,)
        Each example's shift weight.
    seed, patch_size, k : int
        As in :class:`~.params.SynthesisParams`.
    """

    searches: list
    detail: list
    anchor: np.ndarray
    seed: int
    patch_size: int
    k: int

    def key(self) -> tuple:
        """Equal for kits that are the same: the searches and the detail
        are the memos' shared objects (by ``id``: a kept kit holds them,
        so no other object takes their ids while it is kept), the rest by
        value."""
        return (tuple(map(id, self.searches)), tuple(map(id, self.detail)), self.anchor.tobytes(), self.seed,
                self.patch_size, self.k)


@dataclass(frozen=True, eq=False)
class WindowTask:
    """One fill window and the neighbourhood it reads.

    Parameters
    ----------
    box : (r0, r1, c0, c1)
        The neighbourhood (window plus a one-cell ring, clipped), output cells.
    bbox : (r0, r1, c0, c1)
        The window, output cells.
    canvas : Canvas
        The output over ``box`` (:meth:`Canvas.crop`).
    level : ndarray of float32, shape of ``box``
        The level field over ``box``, metres.
    members : list of int
        Examples of the styles in the window.
    relief : float
        Their largest relief, metres (cost unit).
    number : int
        The window's number in the fill (seeds its random choices).
    index : int
        The patch's index in the run's records.
    """

    box: tuple
    bbox: tuple
    canvas: Canvas
    level: np.ndarray
    members: list
    relief: float
    number: int
    index: int


def window_task(canvas: Canvas, level: np.ndarray, bbox, members: list[int], relief: float, *, number: int,
                index: int) -> WindowTask:
    """The task of filling window ``bbox`` of ``canvas``."""
    rows, cols = canvas.shape
    r0, r1, c0, c1 = bbox
    box = (max(r0 - 1, 0), min(r1 + 1, rows), max(c0 - 1, 0), min(c1 + 1, cols))
    return WindowTask(box, tuple(bbox), canvas.crop(box), level[box[0]:box[1], box[2]:box[3]].copy(),
                      members, relief, number, index)


def fill_window(kit: FillKit, task: WindowTask) -> tuple[Canvas, PatchRecord]:
    """Search, cut, place and blend one window on its task's canvas.

    Returns
    -------
    canvas : Canvas
        The task's canvas with the patch merged.
    record : PatchRecord
        In output cells.
    """
    canvas = task.canvas
    R0, C0 = task.box[0], task.box[2]
    r0, r1, c0, c1 = task.bbox
    local = (r0 - R0, r1 - R0, c0 - C0, c1 - C0)
    win = (slice(local[0], local[1]), slice(local[2], local[3]))
    rng = np.random.default_rng([kit.seed, 1, task.number])
    options = search_fill(kit.searches, kit.detail, kit.anchor, task.members, task.relief,
                          canvas.heights[win] - task.level[win], canvas.filled[win].copy(), rng,
                          patch_size=kit.patch_size, k=kit.k)
    rec = choose_fill(canvas, local, options, kit.detail, task.level, index=task.index, patch_size=kit.patch_size,
                      rng=rng)
    canvas.blend(local)
    # A window reads pages of many examples of its style: over a large
    # library the mapped pages it touched are handed back past the budget,
    # here and in each worker process alike.
    keep_within_budget()
    return canvas, replace(rec, bbox=task.bbox)


class FillWorkers:
    """Fills waves of windows with ``processes`` processes (this one
    included); use as a context manager.

    Parameters
    ----------
    kit : FillKit
    processes : int
        1 fills every window here.
    """

    def __init__(self, kit: FillKit, processes: int):
        self.kit = kit
        self.processes = max(1, int(processes))
        self._workers = None

    def __enter__(self) -> "FillWorkers":
        if self.processes > 1:
            # Kept for the next stage with the same kit: a live stroke's fill
            # finds it with the workers, its indexes loaded.
            self._workers = KitWorkers(self.kit, self.processes, keep=self.kit.key())
        return self

    def __exit__(self, *exc) -> None:
        if self._workers is not None:
            self._workers.__exit__(*exc)

    def run(self, tasks: list[WindowTask]) -> list[tuple[Canvas, PatchRecord]]:
        """Fill the windows of one wave; results in the tasks' order."""
        if self._workers is None:
            return [fill_window(self.kit, t) for t in tasks]
        # Every ``processes``-th task here, the others to the workers.
        futures = {i: self._workers.submit(fill_window, t) for i, t in enumerate(tasks) if i % self.processes}
        here = {i: fill_window(self.kit, t) for i, t in enumerate(tasks) if i not in futures}
        return [here[i] if i in here else futures[i].result() for i in range(len(tasks))]
