"""Framed feature warps: the ground across a feature keeps its scale, and
warps that fold or streak are measured as such."""

import math

import numpy as np
import pytest

from terrasynth_core.warping.frame import frame_points, framed, framed_bending_energies
from terrasynth_core.warping.thin_plate import ThinPlateSpline, bending_energies, warp_distortion

R = 40.0


def _path(sagitta: float, centre=(100.0, 100.0)) -> np.ndarray:
    """Centre, then two crossings of a circle of radius R by a path bent
    by ``sagitta`` cells (0: straight, along the columns)."""
    c = np.asarray(centre, float)
    return np.array([c, c + [sagitta, -R], c + [sagitta, R]])


def test_frame_points_sit_in_the_wide_gaps_on_the_circle():
    path = frame_points(_path(0.0))
    assert path.shape == (2, 2)
    # Across the path, one either side, on the crossings' circle.
    np.testing.assert_allclose(np.sort(path[:, 0]), [100 - R, 100 + R], atol=1e-9)
    np.testing.assert_allclose(path[:, 1], [100, 100], atol=1e-9)
    end = frame_points(np.array([[0.0, 0.0], [0.0, R]]))
    assert end.shape == (2, 2)  # behind an end
    branch = np.array([[0.0, 0.0]] + [[R * math.cos(a), R * math.sin(a)] for a in (0.3, 0.3 + 2.1, 0.3 + 4.2)])
    assert frame_points(branch).shape == (0, 2)  # gaps of 120 degrees: none


def test_a_bent_target_on_a_straight_example_bends_instead_of_squeezing():
    # The case that streaked rings: a stroke on a circle of radius 170
    # (sagitta 4.7 cells over the patch) from a nearly straight ridge.
    target, control = _path(4.7), _path(0.3, centre=(300.0, 250.0))
    bare = ThinPlateSpline.fit(target, control, regularization=1e-3)
    frame = ThinPlateSpline.fit(*framed(target, control, reflect=False), regularization=1e-3)
    top_left, shape = (60, 60), (80, 80)
    assert warp_distortion(bare, top_left, shape) > 10.0
    assert warp_distortion(frame, top_left, shape) < 1.5
    # Both still carry every control point exactly.
    np.testing.assert_allclose(frame.transform(target), control, atol=1e-2)


def test_mirrored_candidates_get_a_reflecting_frame():
    target = _path(3.0)
    mirrored = target.copy()
    mirrored[:, 0] = 2 * target[0, 0] - mirrored[:, 0]  # reflected across the path's chord
    tps = ThinPlateSpline.fit(*framed(target, mirrored, reflect=True))
    assert warp_distortion(tps, (60, 60), (80, 80)) < 1.01  # a pure reflection
    assert np.all(np.linalg.det(tps.jacobian(target)) < 0)


def test_framed_energies_match_one_fit_each_and_grow_with_the_bend():
    target = _path(0.0)
    controls = np.stack([_path(s) for s in (0.0, 2.0, 8.0)])
    reflect = np.zeros(3, bool)
    energies = framed_bending_energies(target, controls, reflect)
    assert energies[0] == pytest.approx(0.0, abs=1e-9)
    assert 0 < energies[1] < energies[2]
    single = [bending_energies(*(p[None] if i else p for i, p in enumerate(framed(target, c, reflect=False))))[0]
              for c in controls]
    np.testing.assert_allclose(energies, single, rtol=1e-9, atol=1e-12)


def test_jacobian_matches_finite_differences():
    rng = np.random.default_rng(3)
    src = rng.uniform(0, 80, (6, 2))
    tps = ThinPlateSpline.fit(src, src + rng.normal(scale=4.0, size=src.shape))
    pts = rng.uniform(0, 80, (20, 2))
    h = 1e-5
    numeric = np.stack([(tps.transform(pts + [h, 0]) - tps.transform(pts - [h, 0])) / (2 * h),
                        (tps.transform(pts + [0, h]) - tps.transform(pts - [0, h])) / (2 * h)], axis=-1)
    np.testing.assert_allclose(tps.jacobian(pts), numeric, atol=1e-6)


def test_distortion_flags_folds_and_scores_similarities_one():
    target = _path(0.0)
    turned = ThinPlateSpline.similarity(target, target[:, ::-1] * 1.3)
    assert warp_distortion(turned, (60, 60), (80, 80)) == pytest.approx(1.0)
    # Pulling the centre across a crossing folds the map.
    folded = target.copy()
    folded[0] = target[2] + [0.0, 15.0]
    tps = ThinPlateSpline.fit(target, folded)
    assert warp_distortion(tps, (60, 60), (80, 80)) == math.inf
