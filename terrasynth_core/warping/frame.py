"""Frame points: a feature warp that bends the feature, not the ground
around it.

A path sample has three control points, its centre and the two places
where the feature crosses the patch's inscribed circle.  Three points fix
an affine map exactly, and an affine map that carries a slightly bent
triangle onto a nearly straight one (a curved stroke, a straight example
ridge) squeezes the direction across the feature by the ratio of the two
bends: 10-20x on a ring of strokes, where the warped ridges came out as
streaks across the stroke; where the bends have opposite signs the map
folds and the patch shows whorls.  Nothing in the three points asks for
that squeeze; it is the affine interpolant's guess.

So where the sketch sample has no control point, the map is told what to
do: *frame points* on the same circle, in every wide gap between the
crossings (across a path, behind an end), are carried by the least-squares
similarity (rotation, uniform scale, and a reflection for mirrored
candidates) of the real points.  The spline still carries every real
control point exactly, bends where the two features' shapes differ, and
keeps the ground across the feature at its own scale.  Its bending energy
then measures the shape difference of paths too, which ranks the
candidates (:mod:`terrasynth_core.matching.candidates`).
"""

from __future__ import annotations

import numpy as np

from ..memo import Memo
from .thin_plate import bending_energies, similarity_params

__all__ = ["FRAME_GAP", "frame_points", "framed", "framed_bending_energies"]

#: A gap between consecutive crossings (seen from the centre) gets one frame
#: point per this many radians: a path's two 180-degree gaps one each, an
#: end's 360-degree gap two, a branch's 120-degree gaps none.
FRAME_GAP = np.deg2rad(150.0)


def frame_points(points: np.ndarray) -> np.ndarray:
    """Frame points of a control set whose first point is its centre.

    Parameters
    ----------
    points : ndarray of float64, shape (n, 2)
        The centre, then the crossings, ``(row, col)``; n >= 2.

    Returns
    -------
    ndarray of float64, shape (f, 2)
        Points on the crossings' mean circle, spread evenly inside every
        gap between consecutive crossings of at least :data:`FRAME_GAP`
        (f may be 0).
    """
    centre = points[0]
    rel = points[1:] - centre
    if len(rel) == 0:
        return np.zeros((0, 2))
    radius = float(np.mean(np.hypot(rel[:, 0], rel[:, 1])))
    if radius <= 0.0:
        return np.zeros((0, 2))
    angles = np.sort(np.arctan2(rel[:, 1], rel[:, 0]))
    gaps = np.diff(np.append(angles, angles[0] + 2 * np.pi))
    out = []
    for start, gap in zip(angles, gaps):
        k = int(gap // FRAME_GAP)
        for j in range(1, k + 1):
            a = start + gap * j / (k + 1)
            out.append(centre + radius * np.array([np.cos(a), np.sin(a)]))
    return np.array(out).reshape(-1, 2)


#: Frame points by their control set's bytes (:func:`_frame_of`).
_FRAMES = Memo(256)


def _frame_of(points: np.ndarray) -> np.ndarray:
    """:func:`frame_points` of ``points``, kept: every candidate of a
    feature patch frames the same sketch control set.  Read-only."""
    points = np.asarray(points, dtype=np.float64)

    def make():
        frame = frame_points(points)
        frame.flags.writeable = False
        return frame

    return _FRAMES.get((points.shape, points.tobytes()), make)


def _apply(a: np.ndarray, b: np.ndarray, points: np.ndarray, reflect: np.ndarray) -> np.ndarray:
    z = points[:, 0] + 1j * points[:, 1]
    z = np.where(reflect[:, None], np.conj(z)[None, :], z[None, :])
    w = a[:, None] * z + b[:, None]
    return np.stack([w.real, w.imag], axis=-1)


def framed(src: np.ndarray, dst: np.ndarray, *, reflect: bool) -> tuple[np.ndarray, np.ndarray]:
    """One control set with its frame points on both sides.

    Parameters
    ----------
    src : ndarray of float64, shape (n, 2)
        Centre first, then crossings (the side the spline maps *from*).
    dst : ndarray of float64, shape (n, 2)
        Where they go.
    reflect : bool
        The map includes a reflection (a mirrored candidate).

    Returns
    -------
    src_all, dst_all : ndarray of float64, shape (n + f, 2)
    """
    frame = _frame_of(src)
    if len(frame) == 0:
        return src, dst
    flag = np.array([bool(reflect)])
    a, b = similarity_params(src, dst[None], flag)
    return np.vstack([src, frame]), np.vstack([dst, _apply(a, b, frame, flag)[0]])


def framed_bending_energies(src: np.ndarray, dst: np.ndarray, reflect: np.ndarray) -> np.ndarray:
    """Bending energies of the framed splines from one control set onto many.

    Parameters
    ----------
    src : ndarray of float64, shape (n, 2)
        Centre first, then crossings.
    dst : ndarray of float64, shape (M, n, 2)
    reflect : ndarray of bool, shape (M,)

    Returns
    -------
    ndarray of float64, shape (M,)
        As :func:`~terrasynth_core.warping.thin_plate.bending_energies` of
        :func:`framed` pairs; in the square of ``src``'s units.
    """
    frame = _frame_of(src)
    if len(frame) == 0:
        return bending_energies(src, dst)
    a, b = similarity_params(src, dst, reflect)
    return bending_energies(np.vstack([src, frame]), np.concatenate([dst, _apply(a, b, frame, reflect)], axis=1))
