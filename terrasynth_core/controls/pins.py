"""Elevation pins: heights the user sets at chosen cells (the paper's future
work, §7 of Zhou et al. 2007: "constrain the Poisson solve").

The synthesized terrain ``h`` is corrected by a field ``d`` that is exactly
the pin's residual at each pin, zero (with zero slope) at ``radius`` cells
from every pin, and otherwise as smooth as possible: it minimises the
squared discrete Laplacian of ``d`` (a biharmonic, thin-plate solve).  The
result keeps the synthesized gradients up to a smooth, local dome or dish.
A plain Poisson (harmonic) correction would pull a single cell into a cone
tip; the squared-Laplacian energy is its C1 counterpart, the continuity the
paper names as future work for its seam solve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse.linalg import splu

from ..errors import ParamsError


@dataclass(frozen=True)
class Pin:
    """A wanted height at one output cell.

    Parameters
    ----------
    row, col : int
        Output cell.
    height : float
        Wanted height, metres (in the final output's frame).
    """

    row: int
    col: int
    height: float


@dataclass(frozen=True)
class PinError:
    """How well a pin was met: ``error = height - target`` (metres)."""

    row: int
    col: int
    target: float
    height: float
    error: float


def check_pins(pins: Sequence[Pin], shape: tuple[int, int]) -> tuple[Pin, ...]:
    """Validate pins against an output shape.

    Raises
    ------
    ParamsError
        A pin that is not a :class:`Pin`, lies outside the output, has a
        non-finite height, or two pins on the same cell.
    """
    out = []
    seen = set()
    for pin in pins:
        if not isinstance(pin, Pin):
            raise ParamsError(f"pins must be Pin(row, col, height), got {pin!r}")
        if not all(isinstance(v, (int, float, np.integer, np.floating)) and math.isfinite(v)
                   for v in (pin.row, pin.col)):
            raise ParamsError(f"pin at ({pin.row}, {pin.col}): row and column must be whole cells of the "
                              f"{shape[0]}x{shape[1]} output")
        r, c = int(pin.row), int(pin.col)
        if r != pin.row or c != pin.col or not (0 <= r < shape[0] and 0 <= c < shape[1]):
            raise ParamsError(
                f"pin at ({pin.row}, {pin.col}) is outside the {shape[0]}x{shape[1]} output "
                f"(rows 0-{shape[0] - 1}, columns 0-{shape[1] - 1})"
            )
        if not math.isfinite(pin.height):
            raise ParamsError(f"pin at ({r}, {c}) has a non-finite height {pin.height}")
        if (r, c) in seen:
            raise ParamsError(f"two pins on cell ({r}, {c}): keep one")
        seen.add((r, c))
        out.append(Pin(r, c, float(pin.height)))
    return tuple(out)


def check_pin_heights(pins: Sequence[Pin], allowed: tuple[float, float], rule: str) -> None:
    """Refuse a pin whose height lies outside ``allowed`` (lo, hi) metres.

    ``rule`` says where the range comes from, for the message.
    """
    lo, hi = allowed
    for pin in pins:
        if not lo <= pin.height <= hi:
            raise ParamsError(f"pin at ({pin.row}, {pin.col}): height {pin.height:g} m is outside "
                              f"{lo:.0f}..{hi:.0f} m ({rule})")


def apply_pins(heights: np.ndarray, pins: Sequence[Pin], *, radius: float,
               locked: np.ndarray | None = None) -> tuple[np.ndarray, tuple[PinError, ...]]:
    """Bend ``heights`` smoothly so every pin is met exactly.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Metres; not modified.
    pins : sequence of Pin
        Validated with :func:`check_pins`.
    radius : float
        Cells from a pin beyond which nothing changes (> 2).
    locked : ndarray of bool, shape (rows, cols), optional
        Cells that must not change (outside a local re-synthesis).  A pin on
        a locked cell is reported but not enforced.

    Returns
    -------
    heights : ndarray of float32, shape (rows, cols)
    errors : tuple of PinError
        One per pin, after the correction (float32 round-off for pins on
        free cells).
    """
    pins = tuple(pins)
    out = np.array(heights, dtype=np.float32, copy=True)
    if pins:
        if radius <= 2:
            raise ParamsError(f"pin radius must be more than 2 cells, got {radius}")
        locked = np.zeros(out.shape, bool) if locked is None else np.asarray(locked, bool)
        # Pins whose discs overlap are solved together, others alone: each
        # solve is no bigger than it needs to be.
        reach = np.zeros(out.shape, bool)
        for p in pins:
            reach[p.row, p.col] = True
        reach = ndimage.distance_transform_edt(~reach) < radius
        groups, _ = ndimage.label(reach)
        for g, box in enumerate(ndimage.find_objects(groups), start=1):
            members = [p for p in pins if groups[p.row, p.col] == g]
            r0, r1, c0, c1 = box[0].start, box[0].stop, box[1].start, box[1].stop
            free = (groups[r0:r1, c0:c1] == g) & ~locked[r0:r1, c0:c1]
            local = [(p.row - r0, p.col - c0, p.height - float(out[p.row, p.col])) for p in members
                     if free[p.row - r0, p.col - c0]]
            if local:
                d = smooth_correction(free, local)
                out[r0:r1, c0:c1] += d.astype(np.float32)
        # The solve meets the pins to round-off; float32 addition may not.
        for p in pins:
            if not locked[p.row, p.col]:
                out[p.row, p.col] = np.float32(p.height)
    errors = tuple(PinError(p.row, p.col, p.height, float(out[p.row, p.col]),
                            float(out[p.row, p.col]) - p.height) for p in pins)
    return out, errors


def smooth_correction(free: np.ndarray, pins: list[tuple[int, int, float]]) -> np.ndarray:
    """The least-bending field that is ``value`` at each pin and 0 off ``free``.

    Minimises ``sum (Laplacian d)^2`` over every cell of ``free`` and its
    4-neighbours, with ``d = 0`` on cells outside ``free`` (so the field
    leaves the free area with zero value and, through the Laplacian rows
    just outside, zero slope).  Also the drainage step's solver
    (:mod:`.drainage`, through :func:`smooth_correction_cells`), with the
    stroke centrelines as its pins.

    Parameters
    ----------
    free : ndarray of bool, shape (rows, cols)
        Cells that may change.
    pins : list of (row, col, value)
        Cells of ``free`` whose value is set; no cell twice.

    Returns
    -------
    ndarray of float64, shape (rows, cols)
    """
    shape = free.shape
    pinned = np.zeros(shape, bool)
    value = np.zeros(shape)
    for r, c, v in pins:
        pinned[r, c] = True
        value[r, c] = v
    out = value.copy()
    cells = np.flatnonzero(free)
    out.ravel()[cells] = smooth_correction_cells(shape, cells, pinned.ravel()[cells], value.ravel()[cells])
    return out


def positions(cells: np.ndarray, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where each of ``wanted`` is in ``cells`` (increasing, not empty),
    and whether it is there at all.

    Returns
    -------
    at : ndarray of int64, the shape of ``wanted``
        Its position (meaningless where not found).
    found : ndarray of bool, the shape of ``wanted``
    """
    at = np.minimum(np.searchsorted(cells, wanted), len(cells) - 1)
    return at, cells[at] == wanted


def smooth_correction_cells(shape: tuple[int, int], cells: np.ndarray, pinned: np.ndarray,
                            values: np.ndarray) -> np.ndarray:
    """:func:`smooth_correction` on a list of cells instead of a mask: what
    a long, thin region (a valley's band across a world-size map) needs,
    whose bounding box would not fit in memory.

    Parameters
    ----------
    shape : (rows, cols)
        The box the cells lie in: the Laplacian rows stop at its edge.
    cells : ndarray of int64, shape (n,)
        The free cells' row-major indices in ``shape``, increasing.
    pinned : ndarray of bool, shape (n,)
        Which of them are set.
    values : ndarray of float, shape (n,)
        Their values where set (the rest are not read).

    Returns
    -------
    ndarray of float64, shape (n,)
        The field on ``cells``.
    """
    rows, cols = shape
    pinned = np.asarray(pinned, bool)
    out = np.where(pinned, np.asarray(values, np.float64), 0.0)
    unknown = ~pinned
    n = int(unknown.sum())
    if n == 0:
        return out
    # Unknowns first, then pinned cells (known values), both row-major;
    # cells off the list are the zero border, which needs no columns.
    column = np.empty(len(cells), np.int64)
    column[unknown] = np.arange(n)
    n_pin = len(cells) - n
    column[pinned] = n + np.arange(n_pin)
    r, c = np.divmod(cells, cols)
    # One Laplacian row per free cell and per 4-neighbour of one in the box,
    # row-major.
    around = [cells]
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        rr, cc = r + dr, c + dc
        inside = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
        around.append(rr[inside] * cols + cc[inside])
    equations = np.unique(np.concatenate(around))
    er, ec = np.divmod(equations, cols)
    # 5-point Laplacian rows: -4 at the cell, +1 at each neighbour that has
    # a column (unknown or pinned); zero-border cells drop out.
    entries_r, entries_c, entries_v = [], [], []
    for dr, dc, w in ((0, 0, -4.0), (-1, 0, 1.0), (1, 0, 1.0), (0, -1, 1.0), (0, 1, 1.0)):
        nr, nc = er + dr, ec + dc
        inside = (nr >= 0) & (nr < rows) & (nc >= 0) & (nc < cols)
        at, found = positions(cells, np.where(inside, nr * cols + nc, -1))
        use = inside & found
        entries_r.append(np.flatnonzero(use))
        entries_c.append(column[at[use]])
        entries_v.append(np.full(int(use.sum()), w))
    A = sparse.csr_matrix((np.concatenate(entries_v), (np.concatenate(entries_r), np.concatenate(entries_c))),
                          shape=(len(equations), n + n_pin))
    A_u, A_p = A[:, :n], A[:, n:]
    known = out[pinned] if n_pin else np.zeros(0)
    rhs = -(A_u.T @ (A_p @ known))
    # The normal equations are symmetric positive definite: a symmetric
    # fill-reducing order with diagonal pivots (a quarter faster than
    # spsolve's default column order on an 89,000-cell drainage solve).
    x = splu((A_u.T @ A_u).tocsc(), permc_spec="MMD_AT_PLUS_A",
             options={"SymmetricMode": True, "DiagPivotThresh": 0.0}).solve(rhs)
    out[unknown] = x
    return out
