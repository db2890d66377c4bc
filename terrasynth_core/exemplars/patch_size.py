"""The patch size a run's examples can serve (issue 10, "small examples").

The paper's 80-cell patch suits an example many patches wide.  A small one
holds few distinct windows of that size along its ridges and valleys, so a
run copies the same few over and over, and each one spans several of the
example's landforms, so a stroke is lost among them.  Measured on the
built-ins (path samples of the kind, counted as windows of
:data:`SAME_WINDOW` cells): the Himalaya example, when it was cropped to
its largest valid rectangle (415x252 cells of 89 m), held 15 ridge and 12
valley windows at 80 cells and 28 and 34 at 48; the White Mountains hold
161 and 119 at 80.  At 48 the Himalaya's strokes stood out
(local TPI z +2.47 / -1.78 against +1.83 / -1.38 at 80, 18 evaluation
runs) and no window supplies more than a tenth of a run's feature patches
in 13 of them (6 at 80).

When the run's patch size is automatic, :func:`fitting_patch_size` takes
the largest of :data:`PATCH_SIZES` (no larger than the output, nor than
any example can hold) at which every example holds at least
:data:`VARIED_POOL` windows of each kind the sketch draws (or, for an
example that never does, :data:`MIN_POOL` at its largest size): twice the
:data:`MIN_POOL` at which the issue caps a window's share at a tenth.  A
pool of just 20 meets the cap only by using nearly every window about
equally, so a stroke gets whichever fits least badly.  Measured on the
whole Himalayan basin (648x587 cells, 55 % valid; 18 and 19 windows at
80, 20 and 20 at 72, 55 and 49 at 48), nine evaluation runs each: at 72
local TPI z +2.07 / -1.50, landform +2.11 / -1.80, reuse within a tenth
in 6 of 9 runs, 64-128-cell power 1.77x the example's; at 48 +2.55 /
-1.98, +2.31 / -2.02, 9 of 9, 1.59x.  In the Middle-earth demo (the
basin at 90 m cells, 21 and 20 windows at 72) the high range broke into
separate massifs at 72 and runs unbroken at 48.

The sizes go down to 32 cells for examples a few patches across.  St.
Helens (460x317 cells of 30 m, one volcano) holds 7 ridge and 3 valley
windows at 80, 8 and 12 at 48 and 28 and 23 at 32; at 80 its strokes
were chained copies of the cone's few gullies and rim (an S-valley at the
0.44 height percentile, a ring of smeared rim pieces), at 32 the ring is
a caldera rim and the valley runs low (0.19) with the landform pass
running.  An example that holds fewer than :data:`MIN_POOL` at every
size takes the largest size where it holds nearly its most
(:data:`MOST_SHARE`; a 187x152 DEM of the Rocky Mountains holds 1 ridge
window at 80 and 9 at 32: at 80 its ridges were smooth smears of one
window); the run says its features will repeat.
Only where no example at all holds a window of a drawn kind does the
size go down to one where some example does.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

#: Sources of one example within this many cells of each other share a
#: window (one piece of the example, copied twice when used twice).
SAME_WINDOW = 20.0
#: Distinct windows of a pool at which the issue caps a window's share of a
#: run's feature patches at a tenth.
MIN_POOL = 20
#: Distinct windows an example must hold at a patch size to be varied
#: enough there (see the module's notes).
VARIED_POOL = 2 * MIN_POOL
#: The automatic patch size's choices, largest (the paper's) first.
PATCH_SIZES = (80, 72, 64, 56, 48, 40, 32)
#: An example short of :data:`MIN_POOL` windows at every size asks for the
#: largest size where it holds this share of its most: a smaller patch for
#: a real gain (a 187x152 DEM: 1 ridge window at 80, 4 at 40, 9 at 32), not
#: for one window more (a whole run at 32 takes 1.3-2.5x the time of one
#: at 80).
MOST_SHARE = 0.75
#: The automatic patch size when no example needs a smaller one.
DEFAULT_PATCH = PATCH_SIZES[0]


def distinct_windows(centres: np.ndarray, window: float = SAME_WINDOW) -> int:
    """How many windows ``centres`` cover: each centre farther than
    ``window`` from every earlier kept one starts a new window.

    Parameters
    ----------
    centres : ndarray of float, shape (N, 2)
        Sample centres of one example, cells.
    window : float
        Cells.

    Returns
    -------
    int
    """
    kept = np.empty((0, 2))
    for c in np.asarray(centres, dtype=float).reshape(-1, 2):
        if not (((kept - c) ** 2).sum(axis=1) <= window * window).any():
            kept = np.vstack([kept, c])
    return len(kept)


def path_windows(samples: list) -> int:
    """Distinct windows among the path samples (degree 2) of a pool: most
    of a sketch's feature patches are paths, and the few branch and end
    samples do not make a stroke varied."""
    return distinct_windows(np.array([s.center for s in samples if s.degree == 2], dtype=float).reshape(-1, 2))


def held_windows(field, patch_size: int, kinds: Sequence[str], *, name: str) -> dict:
    """Distinct path windows (:func:`path_windows`) of each kind in
    ``kinds`` that the example holds at a patch size, ``{kind: n}``."""
    from ..errors import ParamsError
    from .prepare import prepare_example  # (here: the parameters import this module's sizes, and start fast)

    try:
        samples = prepare_example(field, patch_size, name=name).samples
    except ParamsError:  # (its voids leave no window of this size: none held)
        return {kind: 0 for kind in kinds}
    return {kind: path_windows(samples[kind]) for kind in kinds}


def fitting_patch_size(fields: Sequence, names: Sequence[str], kinds: Sequence[str], *,
                       largest: int | None = None) -> tuple[int, list[str]]:
    """The automatic patch size for these examples and a sketch drawing
    ``kinds``.

    Parameters
    ----------
    fields : sequence of HeightField or ndarray
        The examples at the run's cell size.
    names : sequence of str
        For the notes.
    kinds : sequence of {"ridge", "valley"}
        The feature kinds the sketch draws; none: the largest size that
        fits, without analysing anything.
    largest : int, optional
        No size above it (the output's smaller side).

    Returns
    -------
    patch_size : int
    notes : list of str
        For the run's warnings: why the size is smaller than the default,
        and which example is too small or too plain to vary at any size.
    """
    # Every example must hold a patch and so must the output (too small
    # for the smallest, the example's analysis or the session says so).
    room = [s for s in PATCH_SIZES if all(_side(f) >= s + 4 for f in fields)]
    sizes = [s for s in room if largest is None or s <= largest]
    if not sizes:
        return PATCH_SIZES[-1], []
    notes = []
    if sizes[0] < DEFAULT_PATCH:
        if room[0] == sizes[0]:
            small = min(zip(fields, names), key=lambda fn: _side(fn[0]))
            why = f"{small[1]} is only {small[0].shape[0]}x{small[0].shape[1]} cells"
        else:
            why = f"the output is only {largest} cells across"
        notes.append(f"patch size at most {sizes[0]} cells (automatic, not {DEFAULT_PATCH}): {why}")
    if not kinds or not fields:
        return sizes[0], notes
    counted: dict = {}

    def count(i: int, size: int) -> dict:
        if (i, size) not in counted:
            counted[i, size] = held_windows(fields[i], size, kinds, name=names[i])
        return counted[i, size]

    def held(i: int, size: int, of: Sequence[str] = kinds) -> int:
        """Example ``i``'s fewest windows at ``size`` among the kinds ``of``."""
        return min((count(i, size)[k] for k in of), default=0)

    def wanted(i: int) -> int | None:
        """The largest size at which example ``i`` is varied enough, or
        failing that meets the issue's floor, or failing both holds
        :data:`MOST_SHARE` of its most windows (of the kinds it holds at
        the largest size, or at any when none there: a kind it lacks does
        not send the run to the size of its one window); None: it holds no
        window at any size."""
        for need in (VARIED_POOL, MIN_POOL):
            size = next((s for s in sizes if held(i, s) >= need), None)
            if size is not None:
                return size
        have = [k for k in kinds if count(i, sizes[0])[k] > 0] or \
            [k for k in kinds if any(count(i, s)[k] > 0 for s in sizes)]
        most = max(held(i, s, have) for s in sizes)
        return next(s for s in sizes if held(i, s, have) >= MOST_SHARE * most) if most > 0 else None

    # Examples without lines of a kind drawn do not decide the size...
    wants = [wanted(i) for i in range(len(fields))]
    deciding = [i for i, w in enumerate(wants) if w is not None]
    lacking = [i for i in range(len(fields)) if all(held(i, s) < MIN_POOL for s in sizes)]
    size = min((wants[i] for i in deciding), default=sizes[0])
    # ... unless no example holds a window of a kind there at all (the run
    # would have nothing to place on those strokes): then the largest
    # smaller size where they do, if one does.
    def placeable(s: int) -> bool:
        return all(sum(count(i, s)[k] for i in range(len(fields))) > 0 for k in kinds)

    chosen = size
    if not placeable(size):
        size = next((s for s in sizes[sizes.index(size) + 1:] if placeable(s)), size)
    for i in deciding:
        if size < sizes[0] and held(i, sizes[0]) < VARIED_POOL:
            short = {k: n for k, n in count(i, sizes[0]).items() if n < VARIED_POOL}
            at_size = count(i, size)
            # Say which rule chose the size: this example's varied pool, or
            # (no size holding that many) its floor; another example's
            # need; or the first size with a window of every kind drawn.
            if size != chosen:
                rule = "the largest size where the examples hold a window of every kind drawn"
            elif wants[i] != size:
                rule = "the size another example needs"
            elif held(i, size) >= VARIED_POOL:
                rule = f"the largest size where it holds {VARIED_POOL} of each"
            elif held(i, size) >= MIN_POOL:
                rule = f"the largest size where it holds {MIN_POOL} of each (none holds {VARIED_POOL})"
            else:
                rule = f"the largest size where it holds nearly its most (none holds {MIN_POOL})"
            notes.append(f"patch size {size} cells (automatic, not {sizes[0]}): at {sizes[0]} cells {names[i]} "
                         f"holds only {_listed(short)} windows (distinct pieces of its lines), fewer than "
                         f"{VARIED_POOL}; {size} is {rule}: {_listed({k: at_size[k] for k in short})}. Set a "
                         "patch size to choose another")
    for i in lacking:
        short = {k: n for k, n in count(i, size).items() if 0 < n < MIN_POOL}
        if not short:
            continue  # (an example without such lines: said where it matters, not as repetition)
        notes.append(f"{names[i]} holds only {_listed(short)} windows (distinct pieces of its lines) at {size} "
                     f"cells, fewer than {MIN_POOL} at any patch size from {sizes[0]} to {sizes[-1]}: its "
                     "features will repeat; a larger example, or one with more ridges and valleys, would help")
    return size, notes


def _side(field) -> int:
    return min(field.shape[:2])


def _listed(counts: dict) -> str:
    """``{"ridge": 15, "valley": 12}`` -> ``"15 ridge and 12 valley"``."""
    return " and ".join(f"{n} {kind}" for kind, n in counts.items())
