"""Thin-plate spline warps of example patches onto sketch features.

A matched example patch rarely has its ridge exactly where the sketch wants
it.  Zhou et al. (2007, §4.1) bend the patch with a thin-plate spline that
carries the example's control points (feature point and the places where the
feature crosses the patch's inscribed circle) onto the sketch's, and rank the
candidates by the spline's bending energy.

Coordinates are ``(row, col)`` in grid cells throughout.

References
----------
.. [1] F. L. Bookstein, "Principal warps: thin-plate splines and the
   decomposition of deformations", IEEE TPAMI 11(6):567-585, 1989.
.. [2] H. Zhou, J. Sun, G. Turk, J. M. Rehg, "Terrain synthesis from digital
   elevation models", IEEE TVCG 13(4):834-848, 2007.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from ..errors import ParamsError
from ..memo import Memo

#: Relative size (to the point spread) below which two control points count
#: as the same point.
_DEGENERACY_TOL = 1e-9

#: Cells of margin kept around the sampled area when cropping the source for
#: ``map_coordinates``; splines of order > 1 are prefiltered on the crop, and
#: their coefficients' dependence on far cells decays by about 0.27 per cell,
#: so 12 cells make the crop's effect negligible (< 1e-6 relative).
_CROP_MARGIN = 12


def radial_kernel(r2: np.ndarray) -> np.ndarray:
    """Bookstein's ``U = r^2 log r^2`` from squared distances (``U(0) = 0``).

    Parameters
    ----------
    r2 : ndarray of float64, any shape
        Squared distances, cells squared.

    Returns
    -------
    ndarray of float64, the shape of ``r2``
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        u = r2 * np.log(r2)
    return np.where(r2 > 0.0, u, 0.0)


def squared_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(len(a), len(b))`` squared Euclidean distances between point sets."""
    dr = a[:, 0, None] - b[None, :, 0]
    dc = a[:, 1, None] - b[None, :, 1]
    return dr * dr + dc * dc


def kernel_energy(weights: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Bending energies ``sum_k w_k^T K w_k`` of splines sharing their kernel.

    Parameters
    ----------
    weights : ndarray of float64, shape (M, n, 2)
        Kernel weights of M splines with the same n control points.
    kernel : ndarray of float64, shape (n, n)
        ``U(|p_i - p_j|)`` of those control points.

    Returns
    -------
    ndarray of float64, shape (M,)
        Clipped at 0: ``w^T K w`` is non-negative on the space ``P^T w = 0``
        the weights live in, up to round-off.
    """
    return np.maximum(np.einsum("mik,ij,mjk->m", weights, kernel, weights), 0.0)


def bending_energies(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """Bending energies of the interpolating splines from one point set onto many.

    Parameters
    ----------
    src : ndarray of float64, shape (n, 2)
        Control points, distinct.
    dst : ndarray of float64, shape (M, n, 2)
        M point sets the control points are carried onto.

    Returns
    -------
    ndarray of float64, shape (M,)
        The same quantity as :attr:`ThinPlateSpline.bending_energy` of
        ``ThinPlateSpline.fit(src, dst[i])`` for general ``src``, all from
        one inverse of the spline's system; zeros when ``src`` leaves the
        system singular (e.g. collinear points).
    """
    m = src.shape[0]
    k = radial_kernel(squared_distances(src, src))
    system = np.zeros((m + 3, m + 3))
    system[:m, :m] = k
    system[:m, m:] = np.hstack([np.ones((m, 1)), src])
    system[m:, :m] = system[:m, m:].T
    try:
        inverse = np.linalg.inv(system)
    except np.linalg.LinAlgError:
        return np.zeros(dst.shape[0])
    weights = np.einsum("ij,mjk->mik", inverse[:m, :m], dst)
    return kernel_energy(weights, k)


def _as_points(points, name: str) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ParamsError(f"{name} must be an (n, 2) array of (row, col) points, got shape {p.shape}")
    if not np.isfinite(p).all():
        raise ParamsError(f"{name} holds non-finite coordinates")
    return p


def similarity_params(src: np.ndarray, dst: np.ndarray, reflect: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares similarities ``z' = a z + b`` (or ``a conj(z) + b``
    where ``reflect``) taking one point set onto many, points as complex
    numbers ``row + i col``.

    Parameters
    ----------
    src : ndarray of float64, shape (n, 2)
    dst : ndarray of float64, shape (M, n, 2)
    reflect : ndarray of bool, shape (M,)

    Returns
    -------
    a, b : ndarray of complex128, shape (M,)
    """
    zs = src[:, 0] + 1j * src[:, 1]
    zs = np.where(reflect[:, None], np.conj(zs)[None, :], zs[None, :])  # (M, n)
    zd = dst[..., 0] + 1j * dst[..., 1]
    ms, md = zs.mean(axis=1, keepdims=True), zd.mean(axis=1, keepdims=True)
    denom = np.sum(np.abs(zs - ms) ** 2, axis=1)
    num = np.sum(np.conj(zs - ms) * (zd - md), axis=1)
    a = np.where(denom > 0, num / np.where(denom > 0, denom, 1.0), 1.0 + 0j)
    b = md[:, 0] - a * ms[:, 0]
    return a, b



#: Spline systems by their source control points (:func:`_spline_system`):
#: a feature patch's candidates share the sketch's side of their splines,
#: so its system is made once for all of them.
_SYSTEMS = Memo(64)


def _spline_system(src: np.ndarray, regularization: float, collinear_tolerance: float) -> tuple:
    """What :meth:`ThinPlateSpline.fit` derives from its source points alone.

    Parameters
    ----------
    src : ndarray of float64, shape (n, 2)
        Checked source control points, n >= 1.
    regularization, collinear_tolerance : float
        As in :meth:`ThinPlateSpline.fit`.

    Returns
    -------
    center : ndarray of float64, shape (2,)
        The points' mean.
    virtual : ndarray of float64, shape (2,), or None
        The virtual control point added to a (nearly) collinear set.
    kernel_src : ndarray of float64, shape (m, 2)
        The spline's kernel centres (``src``, then ``virtual``); only for
        n >= 3.
    system : ndarray of float64, shape (m + 3, m + 3), or None
        The interpolation system; None for n <= 2 (no kernel).

    Raises
    ------
    ParamsError
        Two source points coincide.
    """
    # Its own copy: the memo keeps and freezes what it returns, and the
    # caller's array (or the buffer it views) must stay the caller's.
    src = np.array(src, dtype=np.float64)
    n = len(src)
    center = src.mean(axis=0)
    spread = float(np.sqrt(((src - center) ** 2).sum(axis=1).max()))
    tol = _DEGENERACY_TOL * max(spread, 1.0)
    if n > 1:
        d2 = squared_distances(src, src)
        d2[np.diag_indices(n)] = np.inf
        if d2.min() <= tol * tol:
            i, j = np.unravel_index(np.argmin(d2), d2.shape)
            raise ParamsError(
                f"src control points {i} and {j} coincide at {tuple(src[i])}; expected distinct points"
            )
    if n <= 2:
        return center, None, None, None

    # Collinear: the centred points' smaller singular value is ~ 0, or
    # small against the larger one.
    virtual = None
    _, sing, vt = np.linalg.svd(src - center, full_matrices=False)
    if sing[-1] <= max(tol * math.sqrt(n), collinear_tolerance * sing[0]):
        virtual = center + spread * vt[-1]
        src = np.vstack([src, virtual])
        n += 1

    x = src - center
    k = radial_kernel(squared_distances(src, src))
    system = np.zeros((n + 3, n + 3))
    system[:n, :n] = k + regularization * np.eye(n)
    system[:n, n] = 1.0
    system[:n, n + 1 :] = x
    system[n, :n] = 1.0
    system[n + 1 :, :n] = x.T
    # Shared by every spline fitted on these points: never written to.
    for a in (center, src, system) + (() if virtual is None else (virtual,)):
        a.flags.writeable = False
    return center, virtual, src, system


def _similarity_fit(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rotation + uniform scale + translation taking src to dst.

    Returns ``(linear, offset)`` with ``dst ~ src @ linear.T + offset``
    (exact for two points).
    """
    a, b = similarity_params(src, dst[None], np.zeros(1, bool))
    return _similarity_matrix(a[0], False), np.array([b[0].real, b[0].imag])


def _similarity_matrix(a: complex, reflect: bool) -> np.ndarray:
    """The 2x2 matrix of ``z -> a z`` (or ``a conj(z)``), ``z = row + i col``."""
    if reflect:
        return np.array([[a.real, a.imag], [a.imag, -a.real]])
    return np.array([[a.real, -a.imag], [a.imag, a.real]])


class ThinPlateSpline:
    """A 2-D thin-plate spline map ``f: (row, col) -> (row, col)``.

    ``f(x) = c + L (x - m) + sum_i w_i U(|x - p_i|)`` with ``U(r) = r^2 log r^2``
    (Bookstein 1989), control points ``p_i``, their mean ``m``, an affine part
    ``(c, L)`` and kernel weights ``w`` (one column per output coordinate).
    Build one with :meth:`fit`.

    Attributes
    ----------
    control_points : ndarray of float64, shape (n, 2)
        Source-side kernel centres (may include one virtual point, see
        :meth:`fit`); empty for a purely affine map.
    weights : ndarray of float64, shape (n, 2)
    linear : ndarray of float64, shape (2, 2)
        Linear part ``L`` of the affine term: ``f(x) ~ L x`` far away.
    """

    def __init__(
        self,
        control_points: np.ndarray,
        weights: np.ndarray,
        offset: np.ndarray,
        linear: np.ndarray,
        center: np.ndarray,
    ):
        self.control_points = control_points
        self.weights = weights
        self.linear = linear
        self._offset = offset
        self._center = center
        # Made when first asked for: a feature patch's warps never ask.
        self._bending_energy: float | None = None

    # -- construction ----------------------------------------------------
    @classmethod
    def fit(
        cls, src, dst, *, regularization: float = 0.0, collinear_tolerance: float = 0.05
    ) -> "ThinPlateSpline":
        """Thin-plate spline taking each ``src[i]`` to ``dst[i]``.

        Parameters
        ----------
        src, dst : array_like of float, shape (n, 2)
            Corresponding ``(row, col)`` control points, n >= 1.  ``src`` must
            not repeat a point (``dst`` may: the map then folds).
        regularization : float, default 0.0
            Smoothing ``lambda >= 0`` added to the kernel diagonal; 0
            interpolates the control points exactly, larger values trade
            exactness for less bending.
        collinear_tolerance : float, default 0.05
            ``src`` points whose spread across their best-fit line is at most
            this fraction of the spread along it count as collinear (see
            Notes); 0 keeps only exactly collinear points.  Nearly straight
            control sets (a gently curved path) otherwise pin the affine part
            across the line to tiny offsets and blow it up.

        Returns
        -------
        ThinPlateSpline

        Raises
        ------
        ParamsError
            Shapes differ or are not (n, 2), coordinates are not finite, n is
            0, ``src`` repeats a point, or ``regularization`` or
            ``collinear_tolerance`` is out of range.

        Notes
        -----
        Degenerate control sets fall back gracefully instead of failing:

        * n = 1: a translation.
        * n = 2: the rotation + uniform scale + translation through both
          points (exact).
        * n >= 3 collinear ``src`` points leave the spline's affine part
          undetermined across the line (nearly collinear ones, badly
          determined).  One virtual control point is added
          off the line (at the points' mean, one spread away), mapped by the
          least-squares similarity of the real points; the spline then still
          interpolates every real point, bends to fit them, and behaves like
          that similarity across the line.

        A spline through 3 non-collinear points is always affine (bending
        energy 0).
        """
        src = _as_points(src, "src control points")
        dst = _as_points(dst, "dst control points")
        if src.shape != dst.shape:
            raise ParamsError(f"src and dst control points must have the same shape, got {src.shape} and {dst.shape}")
        n = len(src)
        if n == 0:
            raise ParamsError("a thin-plate spline needs at least 1 control point, got 0")
        if not (regularization >= 0.0 and math.isfinite(regularization)):
            raise ParamsError(f"regularization must be a finite value >= 0, got {regularization}")
        if not 0.0 <= collinear_tolerance < 1.0:
            raise ParamsError(f"collinear_tolerance must be in [0, 1), got {collinear_tolerance}")

        key = (src.tobytes(), float(regularization), float(collinear_tolerance))
        center, virtual, kernel_src, system = _SYSTEMS.get(
            key, lambda: _spline_system(src, regularization, collinear_tolerance))

        empty = np.zeros((0, 2))
        if n == 1:
            return cls(empty, empty, dst[0] - src[0] + center, np.eye(2), center)
        if n == 2:
            linear, offset = _similarity_fit(src, dst)
            return cls(empty, empty, center @ linear.T + offset, linear, center)
        if virtual is not None:
            linear, offset = _similarity_fit(src, dst)
            dst = np.vstack([dst, virtual @ linear.T + offset])
            n += 1

        rhs = np.zeros((n + 3, 2))
        rhs[:n] = dst
        sol = np.linalg.solve(system, rhs)
        weights = sol[:n]
        return cls(kernel_src, weights, sol[n], sol[n + 1 :].T, center)

    @classmethod
    def similarity(cls, src, dst, *, reflect: bool = False) -> "ThinPlateSpline":
        """The least-squares similarity taking ``src`` to ``dst``: rotation,
        uniform scale, translation, and a reflection with ``reflect``.  It
        never folds or stretches one way: the warp of last resort.

        Parameters
        ----------
        src, dst : array_like of float, shape (n, 2)
            Corresponding ``(row, col)`` points, n >= 1.

        Returns
        -------
        ThinPlateSpline
            With no kernel points.
        """
        src = _as_points(src, "src control points")
        dst = _as_points(dst, "dst control points")
        if src.shape != dst.shape:
            raise ParamsError(f"src and dst control points must have the same shape, got {src.shape} and {dst.shape}")
        a, b = similarity_params(src, dst[None], np.array([bool(reflect)]))
        empty = np.zeros((0, 2))
        return cls(empty, empty, np.array([b[0].real, b[0].imag]), _similarity_matrix(a[0], reflect), np.zeros(2))

    # -- evaluation ------------------------------------------------------
    def transform(self, points) -> np.ndarray:
        """Map points.

        Parameters
        ----------
        points : array_like of float, shape (m, 2)
            ``(row, col)`` positions.

        Returns
        -------
        ndarray of float64, shape (m, 2)
        """
        p = _as_points(points, "points")
        kernel = radial_kernel(squared_distances(p, self.control_points)) if len(self.control_points) else None
        return self._transform_with(p, kernel)

    def _transform_with(self, p: np.ndarray, kernel: np.ndarray | None) -> np.ndarray:
        """:meth:`transform` of checked points ``p`` (m, 2) whose kernel
        matrix ``U(|p_i - c_j|)`` (m, n) against the control points is
        given (None without control points)."""
        out = (p - self._center) @ self.linear.T + self._offset
        if kernel is not None:
            out += kernel @ self.weights
        return out

    def jacobian(self, points) -> np.ndarray:
        """Derivatives of the map at points.

        Parameters
        ----------
        points : array_like of float, shape (m, 2)
            ``(row, col)`` positions.

        Returns
        -------
        ndarray of float64, shape (m, 2, 2)
            ``J[i, k, j] = d f_k / d x_j`` at ``points[i]``.
        """
        p = _as_points(points, "points")
        terms = _jacobian_terms(p, self.control_points) if len(self.control_points) else None
        return self._jacobian_with(len(p), terms)

    def _jacobian_with(self, m: int, terms: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
        """:meth:`jacobian` at ``m`` points whose :func:`_jacobian_terms`
        against the control points are given (None without control
        points)."""
        jac = np.broadcast_to(self.linear, (m, 2, 2)).copy()
        if terms is not None:
            g, diff = terms
            jac += np.einsum("nk,mn,mnj->mkj", self.weights, g, diff)
        return jac

    @property
    def bending_energy(self) -> float:
        """Bending energy ``sum_k w_k^T K w_k`` over both output coordinates.

        Proportional to the integral of the squared second derivatives of
        the map (Bookstein 1989); 0 for an affine map, in cells^2 (it grows
        with the square of the displacements).
        """
        if self._bending_energy is None:
            energy = 0.0
            if len(self.control_points):
                k = radial_kernel(squared_distances(self.control_points, self.control_points))
                energy = float(kernel_energy(self.weights[None], k)[0])
            self._bending_energy = energy
        return self._bending_energy


def _jacobian_terms(p: np.ndarray, control_points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The parts of a spline's Jacobian at points ``p`` (m, 2) that depend
    only on where its kernel centres (n, 2) are: ``g`` (m, n), the radial
    factor, and ``diff`` (m, n, 2), the offsets from each centre."""
    diff = p[:, None, :] - control_points[None, :, :]  # (m, n, 2)
    r2 = np.einsum("mnj,mnj->mn", diff, diff)
    with np.errstate(divide="ignore", invalid="ignore"):
        # d/dx of r^2 log r^2 = 2 (x - p) (log r^2 + 1), 0 at r = 0.
        g = np.where(r2 > 0.0, 2.0 * (np.log(r2) + 1.0), 0.0)
    return g, diff


class WarpWindow:
    """An output window that splines are checked and sampled on.

    The candidates of one feature patch are warped onto the same window by
    splines that mostly share their output-side control points (the
    sketch's), so the window keeps its cells' coordinates and, per set of
    control points, the kernel matrix over its cells and the Jacobian's
    terms over its disc: each is computed once for every candidate, with
    the very same floating-point operations as for one.

    Parameters
    ----------
    top_left : (row, col)
        Output coordinates of the window's first cell.
    shape : (h, w)
        Window size, cells, both >= 1.

    Raises
    ------
    ParamsError
        ``shape`` is not positive.
    """

    def __init__(self, top_left, shape):
        h, w = (int(v) for v in shape)
        if h < 1 or w < 1:
            raise ParamsError(f"warp window shape must be positive, got {tuple(shape)}")
        self.top_left = (float(top_left[0]), float(top_left[1]))
        self.shape = (h, w)
        self._cells: np.ndarray | None = None
        self._kernels: dict[bytes, np.ndarray] = {}
        self._discs: dict[int, np.ndarray] = {}
        self._terms: dict[tuple[int, bytes], tuple[np.ndarray, np.ndarray]] = {}

    @property
    def cells(self) -> np.ndarray:
        """Output coordinates of every cell, row by row: shape (h * w, 2)."""
        if self._cells is None:
            h, w = self.shape
            rr, cc = np.mgrid[0:h, 0:w]
            self._cells = np.column_stack([rr.ravel() + self.top_left[0], cc.ravel() + self.top_left[1]])
        return self._cells

    def disc(self, step: int) -> np.ndarray:
        """Cells every ``step`` cells of a grid centred in the window, inside
        its inscribed disc: shape (m, 2), output coordinates."""
        if step not in self._discs:
            h, w = self.shape
            rr, cc = np.mgrid[0:h:step, 0:w:step].astype(float)
            rr, cc = rr + (h - 1 - rr.max()) / 2, cc + (w - 1 - cc.max()) / 2  # centred grid
            radius = min(h, w) / 2
            inside = (rr - (h - 1) / 2) ** 2 + (cc - (w - 1) / 2) ** 2 <= radius**2
            self._discs[step] = np.column_stack([rr[inside] + self.top_left[0], cc[inside] + self.top_left[1]])
        return self._discs[step]

    def coordinates(self, tps: ThinPlateSpline) -> np.ndarray:
        """``tps.transform`` of :attr:`cells`: shape (h * w, 2)."""
        cp = tps.control_points
        if not len(cp):
            return tps._transform_with(self.cells, None)
        key = cp.tobytes()
        kernel = self._kernels.get(key)
        if kernel is None:
            kernel = self._kernels[key] = radial_kernel(squared_distances(self.cells, cp))
        return tps._transform_with(self.cells, kernel)

    def distortion(self, tps: ThinPlateSpline, *, step: int = 4) -> float:
        """:func:`warp_distortion` of ``tps`` on this window."""
        pts = self.disc(step)
        if len(pts) == 0:
            return 1.0
        cp = tps.control_points
        terms = None
        if len(cp):
            key = (step, cp.tobytes())
            terms = self._terms.get(key)
            if terms is None:
                terms = self._terms[key] = _jacobian_terms(pts, cp)
        jac = tps._jacobian_with(len(pts), terms)
        det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
        if not (np.all(det > 0) or np.all(det < 0)):
            return math.inf
        # Singular values of a 2x2 matrix: sqrt of the eigenvalues of J^T J.
        sq = np.einsum("mkj,mkj->m", jac, jac)
        root = np.sqrt(np.maximum(sq * sq - 4.0 * det * det, 0.0))
        big, small = np.sqrt((sq + root) / 2), np.sqrt(np.maximum((sq - root) / 2, 0.0))
        return float(np.max(big / np.maximum(small, 1e-12)))

    def warp(self, source: np.ndarray, tps: ThinPlateSpline, *, order: int = 1, mode: str = "nearest",
             return_valid: bool = False):
        """:func:`warp_patch` of ``source`` through ``tps`` onto this window."""
        src = np.asarray(source)
        if src.ndim != 2 or min(src.shape) < 1:
            raise ParamsError(f"warp source must be a 2-D array, got shape {src.shape}")
        if order not in range(6):
            raise ParamsError(f"interpolation order must be an integer 0-5, got {order}")
        if mode not in ("nearest", "reflect", "mirror"):
            raise ParamsError(f"warp mode must be 'nearest', 'reflect' or 'mirror', got {mode!r}")
        if not np.issubdtype(src.dtype, np.floating):
            src = src.astype(np.float32)

        h, w = self.shape
        coords = self.coordinates(tps)
        rows, cols = src.shape
        cr, cc = coords[:, 0], coords[:, 1]
        # (Per column: the same extremes as along axis 0, without its
        # strided reduction.)
        low, high = (cr.min(), cc.min()), (cr.max(), cc.max())
        if low[0] >= 0.0 and low[1] >= 0.0 and high[0] <= rows - 1 and high[1] <= cols - 1:
            n_inside = len(coords)  # the usual case: every sample inside
        else:
            inside = (cr >= 0.0) & (cr <= rows - 1) & (cc >= 0.0) & (cc <= cols - 1)
            n_inside = int(np.count_nonzero(inside))

        # Crop to the sampled area; "reflect"/"mirror" need the whole source as
        # soon as a sample falls outside it, so crop only when all are inside.
        if mode == "nearest" or n_inside == len(coords):
            margin = _CROP_MARGIN if order > 1 else 1
            lo = np.floor(low).astype(np.int64) - margin
            hi = np.ceil(high).astype(np.int64) + margin + 1
            lo = np.clip(lo, 0, [rows - 1, cols - 1])
            hi = np.clip(hi, lo + 1, [rows, cols])
            src = src[lo[0] : hi[0], lo[1] : hi[1]]
            coords = coords - lo

        patch = ndimage.map_coordinates(src, coords.T, order=order, mode=mode, prefilter=order > 1)
        patch = patch.reshape(h, w).astype(np.float32, copy=False)
        if return_valid:
            # The count over the size: the mean of the 0/1 flags, exactly.
            return patch, n_inside / len(coords)
        return patch


def warp_distortion(tps: ThinPlateSpline, top_left, shape, *, step: int = 4) -> float:
    """How far a warp is from a similarity over the disc inscribed in its
    window: the largest ratio of its local stretch in two directions.

    A warp that squeezes the example one way draws its ridges out into
    streaks; one whose Jacobian changes sign folds the example over itself
    (whorls).  A similarity (with or without a reflection) scores 1.

    Parameters
    ----------
    tps : ThinPlateSpline
        Output-to-source map.
    top_left : (row, col)
        Output coordinates of the window's first cell.
    shape : (h, w)
        Window size, cells.
    step : int, default 4
        Spacing of the cells checked, cells.

    Returns
    -------
    float
        max sigma_1 / sigma_2 of the Jacobian over the disc (>= 1); inf
        where the map folds (its determinant changes sign or vanishes).
    """
    return WarpWindow(top_left, shape).distortion(tps, step=step)


def warp_patch(
    source: np.ndarray,
    tps: ThinPlateSpline,
    top_left,
    shape,
    *,
    order: int = 1,
    mode: str = "nearest",
    return_valid: bool = False,
):
    """Resample ``source`` through a spline onto an output window.

    Output pixel ``(r, c)`` sits at output coordinates ``top_left + (r, c)``
    and takes the value of ``source`` at ``tps.transform(top_left + (r, c))``:
    the spline maps *output* (sketch) coordinates to *source* (example)
    coordinates.

    Parameters
    ----------
    source : ndarray, shape (rows, cols)
        Finite heights, e.g. the example DEM (float32 kept float32).
    tps : ThinPlateSpline
        Output-to-source map.
    top_left : (row, col)
        Output coordinates of the window's first pixel.
    shape : (h, w)
        Window size in cells.
    order : int, default 1
        Spline order of the interpolation (0-5), as in
        ``scipy.ndimage.map_coordinates``.
    mode : {"nearest", "reflect", "mirror"}, default "nearest"
        How samples outside ``source`` are filled.
    return_valid : bool, default False
        Also return the fraction of samples that fell inside ``source``.

    Returns
    -------
    patch : ndarray of float32, shape (h, w)
    valid_fraction : float
        Only with ``return_valid``: share of output pixels whose source
        position lies inside ``[0, rows-1] x [0, cols-1]``.

    Notes
    -----
    Only the part of ``source`` around the sampled positions is passed to
    ``map_coordinates``, so a call costs the same on a 4,000^2 DEM as on a
    small one.  For ``order=1`` this is exact; for higher orders the spline
    prefilter runs on the crop plus a 12-cell margin, which changes values
    by far less than float32 precision.
    """
    return WarpWindow(top_left, shape).warp(source, tps, order=order, mode=mode, return_valid=return_valid)
