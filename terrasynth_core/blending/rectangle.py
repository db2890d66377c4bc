"""Fast exact Poisson solves on a rectangle whose border mixes fixed and
open sides (the capacitance-matrix method).

Nearly every seam solve of a fill is a whole window of free cells: the cells
just outside it either hold terrain (fixed, Dirichlet) or are still empty
(open, Neumann), in a pattern that changes from window to window.  A sparse
LU per pattern costs tens of milliseconds.  Here the all-fixed rectangle is
solved by sine transforms (its Laplacian is diagonal in the DST-I basis),
and the open border edges, a low-rank change of that Laplacian, by the
Sherman-Morrison-Woodbury identity (Buzbee, Dorr, George & Golub 1971):

    (A - U W U^T)^-1 b = A^-1 b + A^-1 U (W^-1 - U^T A^-1 U)^-1 U^T A^-1 b

with ``A`` the all-fixed Laplacian, ``U`` the rim cells that miss an edge
and ``W`` how many edges each misses.  ``U^T A^-1 U`` is read from the rim's
Green's matrix, computed once per rectangle shape.  Two sine-transform
solves and one small dense solve (one row per open rim cell) give the same
answer as the sparse factorization, to float64 round-off.

References
----------
.. [1] B. L. Buzbee, F. W. Dorr, J. A. George, G. H. Golub, "The direct
   solution of the discrete Poisson equation on irregular regions", SIAM J.
   Numer. Anal. 8(4):722-736, 1971.
"""

from __future__ import annotations

import numpy as np
from scipy import fft, linalg

from ..memo import Memo


def _sine_basis(n: int) -> np.ndarray:
    """The orthonormal DST-I matrix of order ``n`` (symmetric, its own
    inverse): what ``scipy.fft.dst(type=1, norm="ortho")`` applies."""
    k = np.arange(1, n + 1)
    return np.sqrt(2.0 / (n + 1)) * np.sin(np.pi * np.outer(k, k) / (n + 1))


class RectangleSolver:
    """Solves ``L d = b`` for the graph Laplacian ``L`` of an ``h`` x ``w``
    block of free cells whose outside neighbours are fixed or open.

    Parameters
    ----------
    shape : (h, w)
        The block, cells (both >= 1).
    """

    def __init__(self, shape: tuple[int, int]):
        h, w = shape
        self.shape = (h, w)
        lam_r = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, h + 1) / (h + 1))
        lam_c = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, w + 1) / (w + 1))
        self._eigen = lam_r[:, None] + lam_c[None, :]
        rim = np.zeros(shape, dtype=bool)
        rim[[0, -1], :] = True
        rim[:, [0, -1]] = True
        self.rim = np.flatnonzero(rim)
        self._green = self._rim_green()

    def _fixed_solve(self, b: np.ndarray) -> np.ndarray:
        """``A^-1 b`` over the last two axes (all outside neighbours fixed)."""
        spectrum = fft.dstn(b, type=1, axes=(-2, -1), norm="ortho")
        return fft.idstn(spectrum / self._eigen, type=1, axes=(-2, -1), norm="ortho")

    def _rim_green(self) -> np.ndarray:
        """``A^-1`` between rim cells, shape (n_rim, n_rim).

        Read from the sine basis directly rather than by solving once per
        rim cell: with ``S`` the orthonormal DST-I matrices and ``lam`` the
        eigenvalues, ``A^-1[(i, j), (i', j')] = sum_kl Sr[i, k] Sr[i', k]
        Sc[j, l] Sc[j', l] / lam[k, l]``.  The rim is two whole rows and
        two columns, so each pair of them is a few dense products of the
        block's side length: 4 ms for 80 x 80 cells, where one transform
        pair per rim cell took 100 ms (and a sparse factorization of one
        window 15-25 ms), so a solver is worth making for any block shape,
        even one seen once.
        """
        h, w = self.shape
        sr, sc = _sine_basis(h), _sine_basis(w)
        inverse = 1.0 / self._eigen
        green = np.empty((self.rim.size, self.rim.size))
        # Rim cells by line: whole rows 0 and h - 1; columns 0 and w - 1
        # between them (as positions in ``self.rim``).
        inner = np.arange(1, h - 1)
        row_cells = {a: np.searchsorted(self.rim, a * w + np.arange(w)) for a in sorted({0, h - 1})}
        col_cells = {b: np.searchsorted(self.rim, inner * w + b) for b in sorted({0, w - 1})} if inner.size else {}
        for a, at_a in row_cells.items():
            for b, at_b in row_cells.items():
                # sum_k Sr[a, k] Sr[b, k] / lam[k, l], then along the row.
                green[np.ix_(at_a, at_b)] = (sc * ((sr[a] * sr[b]) @ inverse)) @ sc
            for b, at_b in col_cells.items():
                # [j, i'] = sum_l Sc[j, l] sum_k Sr[a, k] Sc[b, l] / lam[k, l] Sr[i', k]
                block = sc @ (sc[b][:, None] * inverse.T * sr[a][None, :]) @ sr[inner].T
                green[np.ix_(at_a, at_b)] = block
                green[np.ix_(at_b, at_a)] = block.T
        for a, at_a in col_cells.items():
            for b, at_b in col_cells.items():
                green[np.ix_(at_a, at_b)] = (sr[inner] * (inverse @ (sc[a] * sc[b]))) @ sr[inner].T
        return green

    def capacitance(self, missing: np.ndarray):
        """The factorized small system for one pattern of open edges.

        Parameters
        ----------
        missing : ndarray of int, shape (n_rim,)
            Per rim cell (in :attr:`rim` order), how many of its outside
            neighbours are open (0-4).

        Returns
        -------
        (open, factor)
            Indices into :attr:`rim` of the cells that miss an edge, and the
            Cholesky factor of ``W^-1 - U^T A^-1 U`` (None when no edge is
            open).  Raises ``numpy.linalg.LinAlgError`` when the block is not
            anchored (no fixed neighbour at all).
        """
        open_ = np.flatnonzero(missing)
        if open_.size == 0:
            return open_, None
        system = np.diag(1.0 / missing[open_]) - self._green[np.ix_(open_, open_)]
        return open_, linalg.cho_factor(system, check_finite=False)

    def solve(self, rhs: np.ndarray, open_: np.ndarray, factor) -> np.ndarray:
        """``L^-1 rhs`` for a pattern from :meth:`capacitance`.

        Parameters
        ----------
        rhs : ndarray of float64, shape (h * w,)
            Row-major over the block.

        Returns
        -------
        ndarray of float64, shape (h * w,)
        """
        y = self._fixed_solve(rhs.reshape(self.shape)).ravel()
        if factor is None:
            return y
        cells = self.rim[open_]
        weights = linalg.cho_solve(factor, y[cells], check_finite=False)
        spread = np.zeros(self.shape[0] * self.shape[1])
        spread[cells] = weights
        return y + self._fixed_solve(spread.reshape(self.shape)).ravel()


#: Solvers by block shape; a run uses a handful (the patch and its clipped
#: versions at the map's edges), a live stroke's crop a few more (windows
#: cut by the kept terrain).  Each holds its rim's Green's matrix (about
#: 0.8 MB for 80 x 80 cells, 13 MB for 320 x 320) and takes a few
#: milliseconds to make again.
_SOLVERS = Memo(12)


#: Largest rim (cells) a solver is made for: its Green's matrix holds rim
#: squared float64s (2048 cells: 32 MB, a 512 x 512 block).  The engine's
#: blocks are patch-sized (80 x 80: 316 rim cells); a larger one goes to
#: the sparse LU.
MAX_RIM = 2048


def rectangle_solver(shape: tuple[int, int]) -> RectangleSolver | None:
    """The solver for blocks of ``shape``, kept for the next request (None
    for a rim above :data:`MAX_RIM` cells)."""
    h, w = shape
    if 2 * (h + w) - 4 > MAX_RIM:
        return None
    return _SOLVERS.get(tuple(shape), lambda: RectangleSolver(shape))


def open_edges(block: tuple[int, int, int, int], known: np.ndarray) -> np.ndarray:
    """Per rim cell of ``block``, how many outside neighbours are not fixed.

    Parameters
    ----------
    block : (r0, r1, c0, c1)
        The block of free cells inside ``known``'s grid.
    known : ndarray of bool, shape (H, W)
        Fixed cells with a height; a neighbour beyond the grid is open.

    Returns
    -------
    ndarray of int, shape (n_rim,)
        In :attr:`RectangleSolver.rim` order (row-major over the block).
    """
    r0, r1, c0, c1 = block
    H, W = known.shape
    h, w = r1 - r0, c1 - c0
    count = np.zeros((h, w), dtype=np.int64)
    # Each side: the row or column just outside the block, or nothing.
    count[0, :] += ~known[r0 - 1, c0:c1] if r0 > 0 else 1
    count[-1, :] += ~known[r1, c0:c1] if r1 < H else 1
    count[:, 0] += ~known[r0:r1, c0 - 1] if c0 > 0 else 1
    count[:, -1] += ~known[r0:r1, c1] if c1 < W else 1
    rim = np.zeros((h, w), dtype=bool)
    rim[[0, -1], :] = True
    rim[:, [0, -1]] = True
    return count[rim].astype(np.float64)
