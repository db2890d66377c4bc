"""The patch size a run's examples can serve (issue 10, "small examples").

The paper's 80-cell patch suits an example many patches wide.  A small one
holds few distinct windows of that size along its ridges and valleys, so a
run copies the same few over and over, and each one spans several of the
example's landforms, so a stroke is lost among them.  Measured on the
built-ins (path samples of the kind, counted as windows of
:data:`SAME_WINDOW` cells): the Himalaya example (415x252 cells of 89 m)
holds 15 ridge and 12 valley windows at 80 cells and 28 and 34 at 48; the
White Mountains 161 and 119 at 80.  At 48 the Himalaya's strokes stand out
(local TPI z +2.6 / -1.8 against +1.6 / -1.5 at 80) and no window supplies
more than a tenth of a run's feature patches.

When the run's patch size is automatic, :func:`fitting_patch_size` takes
the largest of :data:`PATCH_SIZES` at which every example holds at least
:data:`MIN_POOL` windows of each kind the sketch draws.  An example that
holds fewer at every size (a single landform such as a volcano) does not
pull the size down: smaller patches would not make it more varied, and the
run says so in its warnings.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

#: Sources of one example within this many cells of each other share a
#: window (one piece of the example, copied twice when used twice).
SAME_WINDOW = 20.0
#: Distinct windows a pool needs for a run not to repeat them.
MIN_POOL = 20
#: The automatic patch size's choices, largest (the paper's) first.
PATCH_SIZES = (80, 72, 64, 56, 48)
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


def fitting_patch_size(fields: Sequence, names: Sequence[str], kinds: Sequence[str]) -> tuple[int, list[str]]:
    """The automatic patch size for these examples and a sketch drawing
    ``kinds``.

    Parameters
    ----------
    fields : sequence of HeightField or ndarray
        The examples at the run's cell size.
    names : sequence of str
        For the notes.
    kinds : sequence of {"ridge", "valley"}
        The feature kinds the sketch draws; none: :data:`DEFAULT_PATCH`.

    Returns
    -------
    patch_size : int
    notes : list of str
        For the run's warnings: why the size is smaller than the default,
        and which example is too small or too plain to vary at any size.
    """
    from .prepare import prepare_example  # (here: the parameters import this module's sizes, and start fast)

    if not kinds or not fields:
        return DEFAULT_PATCH, []
    chosen, lacking = [], []  # (size, name, counts at the first size tried, at the size chosen); (name, counts)
    for field, name in zip(fields, names):
        tried = []
        for size in PATCH_SIZES:
            if _side(field) < size + 4:
                continue  # (prepare_example names it if no size fits)
            counts = {kind: path_windows(prepare_example(field, size, name=name).samples[kind]) for kind in kinds}
            tried.append((size, counts))
            if min(counts.values()) >= MIN_POOL:
                chosen.append((size, name, tried[0], counts))
                break
        else:
            if tried:
                lacking.append((name, tried[-1][1]))
    # Every example must hold a patch (prepare_example names one that cannot).
    fit_all = [s for s in PATCH_SIZES if all(_side(f) >= s + 4 for f in fields)]
    room = fit_all[0] if fit_all else DEFAULT_PATCH
    size = min([room, *(s for s, *_ in chosen)])
    notes = []
    if size == room < DEFAULT_PATCH:
        small = min(zip(fields, names), key=lambda fn: _side(fn[0]))
        notes.append(f"patch size {size} cells (automatic, not {DEFAULT_PATCH}): {small[1]} is only "
                     f"{small[0].shape[0]}x{small[0].shape[1]} cells")
    for s, name, (first, at_first), counts in chosen:
        if s == size < room:
            short = [k for k, n in at_first.items() if n < MIN_POOL]
            at_first, counts = ({k: c[k] for k in short} for c in (at_first, counts))
            notes.append(f"patch size {s} cells (automatic, not {DEFAULT_PATCH}): at {first} cells {name} holds "
                         f"only {_listed(at_first)} windows (distinct pieces of its lines), fewer than {MIN_POOL}; "
                         f"at {s}: {_listed(counts)}. Set a patch size to choose another")
    for name, counts in lacking:
        counts = {k: n for k, n in counts.items() if n < MIN_POOL}
        notes.append(f"{name} holds only {_listed(counts)} windows (distinct pieces of its lines) even at "
                     f"{PATCH_SIZES[-1]} cells, fewer than {MIN_POOL}: its features will repeat; a larger example, "
                     "or one with more ridges and valleys, would help")
    return size, notes


def _side(field) -> int:
    return min(field.shape[:2])


def _listed(counts: dict) -> str:
    """``{"ridge": 15, "valley": 12}`` -> ``"15 ridge and 12 valley"``."""
    return " and ".join(f"{n} {kind}" for kind, n in counts.items())
