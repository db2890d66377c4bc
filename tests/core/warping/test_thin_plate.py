"""Thin-plate splines and patch warping."""

import math
import re

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.errors import ParamsError
from terrasynth_core.warping.thin_plate import ThinPlateSpline, warp_patch

SRC = np.array([[10.0, 12.0], [40.0, 8.0], [25.0, 40.0], [70.0, 65.0], [55.0, 20.0], [12.0, 70.0]])


def _perturbation():
    return np.random.default_rng(7).normal(scale=3.0, size=SRC.shape)


def _similar(points, *, angle: float, scale: float = 1.0, center=(0.0, 0.0), offset=(0.0, 0.0)) -> np.ndarray:
    """Points turned counter-clockwise on a north-up map (rows down) and
    scaled about ``center``, then shifted by ``offset``."""
    cos, sin = math.cos(angle), math.sin(angle)
    linear = scale * np.array([[cos, -sin], [sin, cos]])
    c = np.asarray(center, dtype=float)
    return (np.asarray(points, dtype=float) - c) @ linear.T + c + np.asarray(offset, dtype=float)


def _stretch(tps: ThinPlateSpline) -> float:
    """``1 - s_min / s_max`` of the spline's affine part: 0 for a similarity."""
    s = np.linalg.svd(tps.linear, compute_uv=False)
    return float(1.0 - s[-1] / s[0])


def test_fit_reproduces_control_points():
    dst = SRC + _perturbation()
    tps = ThinPlateSpline.fit(SRC, dst)
    assert np.abs(tps.transform(SRC) - dst).max() < 1e-6


def test_affine_map_has_zero_bending_energy_and_is_reproduced_everywhere():
    linear = np.array([[1.2, 0.3], [-0.2, 0.9]])
    offset = np.array([5.0, -3.0])
    tps = ThinPlateSpline.fit(SRC, SRC @ linear.T + offset)
    assert tps.bending_energy < 1e-9
    probe = np.random.default_rng(1).uniform(-20, 100, size=(50, 2))
    assert np.abs(tps.transform(probe) - (probe @ linear.T + offset)).max() < 1e-8
    np.testing.assert_allclose(tps.linear, linear, atol=1e-10)


def test_bending_energy_grows_with_distortion():
    bump = _perturbation()
    energies = [ThinPlateSpline.fit(SRC, SRC + s * bump).bending_energy for s in (0.5, 1.0, 2.0, 4.0)]
    assert all(e1 > e0 > 0 for e0, e1 in zip(energies, energies[1:]))
    # Weights are linear in the displacements: energy is quadratic.
    assert energies[2] / energies[1] == pytest.approx(4.0, rel=1e-6)


def test_bending_energy_ignores_rigid_motion_of_the_whole_configuration():
    dst = SRC + _perturbation()
    moved = ThinPlateSpline.fit(SRC, _similar(dst, angle=0.7, center=(30.0, 30.0), offset=(4.0, -9.0)))
    assert moved.bending_energy == pytest.approx(ThinPlateSpline.fit(SRC, dst).bending_energy, rel=1e-6)


def test_regularization_smooths_instead_of_interpolating():
    dst = SRC + _perturbation()
    exact = ThinPlateSpline.fit(SRC, dst)
    smooth = ThinPlateSpline.fit(SRC, dst, regularization=50.0)
    assert smooth.bending_energy < exact.bending_energy
    assert np.abs(smooth.transform(SRC) - dst).max() > 1e-3


def test_single_point_is_a_translation():
    tps = ThinPlateSpline.fit([[3.0, 4.0]], [[10.0, -2.0]])
    pts = np.array([[0.0, 0.0], [50.0, 7.0]])
    np.testing.assert_allclose(tps.transform(pts), pts + [7.0, -6.0])
    assert tps.bending_energy == 0.0


def test_two_points_give_the_similarity_through_both():
    src = np.array([[0.0, 0.0], [0.0, 10.0]])
    dst = np.array([[5.0, 5.0], [-15.0, 5.0]])  # rotated a quarter turn, scaled by 2
    tps = ThinPlateSpline.fit(src, dst)
    np.testing.assert_allclose(tps.transform(src), dst, atol=1e-12)
    # A point off the line keeps its shape relative to the two: similarity.
    np.testing.assert_allclose(tps.transform([[10.0, 0.0]]), [[5.0, 25.0]], atol=1e-12)
    assert tps.bending_energy == 0.0
    assert _stretch(tps) == pytest.approx(0.0, abs=1e-12)


def test_collinear_points_interpolate_and_follow_a_similarity_across_the_line():
    src = np.array([[10.0, 10.0], [20.0, 20.0], [30.0, 30.0], [40.0, 40.0]])
    bent = src + np.array([[0.0, 0.0], [2.0, -2.0], [-1.0, 1.0], [0.0, 0.0]])
    tps = ThinPlateSpline.fit(src, bent)
    assert np.abs(tps.transform(src) - bent).max() < 1e-6
    assert tps.bending_energy > 0.0

    sim = dict(angle=0.4, scale=1.5, center=(25.0, 25.0), offset=(3.0, 1.0))
    straight = ThinPlateSpline.fit(src, _similar(src, **sim))
    probe = np.array([[0.0, 50.0], [50.0, 0.0], [25.0, 30.0]])
    np.testing.assert_allclose(straight.transform(probe), _similar(probe, **sim), atol=1e-8)
    assert straight.bending_energy < 1e-9


def test_nearly_straight_control_sets_bend_instead_of_shearing():
    # A gently curved sketch path (0.5 cells off straight) onto a more
    # curved example path (6 cells off): as a general 3-point set the spline
    # would be a pure affine map stretching 12x across the path.
    sketch = np.array([[0.0, 0.0], [0.5, 40.0], [0.0, 80.0]])
    example = np.array([[0.0, 0.0], [6.0, 40.0], [0.0, 80.0]])
    sheared = ThinPlateSpline.fit(sketch, example, collinear_tolerance=0.0)
    assert sheared.bending_energy < 1e-9
    assert _stretch(sheared) > 0.9
    bent = ThinPlateSpline.fit(sketch, example)
    assert np.abs(bent.transform(sketch) - example).max() < 1e-6
    assert _stretch(bent) < 0.1
    assert bent.bending_energy > 0.0
    # A cell 20 across the path stays about 20 away instead of 240.
    across = bent.transform([[20.0, 40.0]])[0]
    assert 10.0 < across[0] < 35.0
    with pytest.raises(ParamsError, match="collinear_tolerance"):
        ThinPlateSpline.fit(sketch, example, collinear_tolerance=1.0)


def test_three_general_points_give_an_affine_map():
    src = np.array([[0.0, 0.0], [0.0, 10.0], [10.0, 0.0]])
    stretched = ThinPlateSpline.fit(src, src * [1.0, 3.0])
    assert stretched.bending_energy < 1e-9
    np.testing.assert_allclose(stretched.linear, np.diag([1.0, 3.0]), atol=1e-10)
    assert _stretch(ThinPlateSpline.fit(src, src + 5.0)) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    "src, dst, words",
    [
        ([[1.0, 2.0], [1.0, 2.0], [5.0, 5.0]], [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], "coincide"),
        ([[1.0, 2.0]], [[1.0, 2.0], [3.0, 4.0]], "same shape"),
        (np.zeros((0, 2)), np.zeros((0, 2)), "at least 1"),
        ([[1.0, 2.0, 3.0]], [[1.0, 2.0, 3.0]], "(n, 2)"),
        ([[np.nan, 2.0]], [[1.0, 2.0]], "non-finite"),
    ],
)
def test_bad_control_points_raise(src, dst, words):
    with pytest.raises(ParamsError, match=re.escape(words)):
        ThinPlateSpline.fit(src, dst)


def test_negative_regularization_raises():
    with pytest.raises(ParamsError, match="regularization"):
        ThinPlateSpline.fit(SRC, SRC, regularization=-1.0)


@pytest.fixture
def dem():
    rng = np.random.default_rng(3)
    return ndimage.gaussian_filter(rng.normal(size=(200, 240)), 3).astype(np.float32) * 100 + 500


def test_identity_warp_returns_the_source_window_exactly(dem):
    tps = ThinPlateSpline.fit(SRC, SRC)
    before = dem.copy()
    patch, valid = warp_patch(dem, tps, (30, 50), (80, 80), return_valid=True)
    assert patch.dtype == np.float32
    np.testing.assert_array_equal(patch, dem[30:110, 50:130])
    assert valid == 1.0
    np.testing.assert_array_equal(dem, before)


def test_warp_follows_the_map_from_output_to_source(dem):
    shift = ThinPlateSpline.fit([[0.0, 0.0]], [[7.0, -4.0]])
    np.testing.assert_array_equal(warp_patch(dem, shift, (20, 30), (40, 50)), dem[27:67, 26:76])

    # A quarter turn of the sampling positions rotates the content the other way.
    window = dem[60:100, 60:100]
    corners = np.array([[60.0, 60.0], [60.0, 99.0], [99.0, 60.0]])
    turn = ThinPlateSpline.fit(corners, _similar(corners, angle=math.pi / 2, center=(79.5, 79.5)))
    np.testing.assert_allclose(warp_patch(dem, turn, (60, 60), (40, 40)), np.rot90(window, -1), atol=1e-3)


def test_valid_fraction_counts_samples_outside_the_source(dem):
    shift = ThinPlateSpline.fit([[0.0, 0.0]], [[0.0, 0.0]])
    patch, valid = warp_patch(dem, shift, (-10, 0), (40, 40), return_valid=True)
    assert valid == pytest.approx(30 / 40)
    # mode="nearest": rows above the DEM repeat its first row.
    np.testing.assert_array_equal(patch[:10], np.broadcast_to(dem[0, :40], (10, 40)))


def test_cubic_warp_on_the_crop_matches_the_full_source(dem):
    tps = ThinPlateSpline.fit(SRC, SRC + _perturbation())
    patch = warp_patch(dem, tps, (40, 60), (80, 80), order=3)
    rr, cc = np.mgrid[0:80, 0:80]
    coords = tps.transform(np.column_stack([rr.ravel() + 40.0, cc.ravel() + 60.0]))
    full = ndimage.map_coordinates(dem, coords.T, order=3, mode="nearest").reshape(80, 80)
    np.testing.assert_allclose(patch, full, rtol=0, atol=1e-3)


def test_warp_rejects_bad_arguments(dem):
    tps = ThinPlateSpline.fit(SRC, SRC)
    with pytest.raises(ParamsError, match="2-D"):
        warp_patch(dem[0], tps, (0, 0), (4, 4))
    with pytest.raises(ParamsError, match="order"):
        warp_patch(dem, tps, (0, 0), (4, 4), order=7)
    with pytest.raises(ParamsError, match="shape"):
        warp_patch(dem, tps, (0, 0), (0, 4))


def test_warp_window_gives_the_bytes_of_one_warp_per_spline():
    # A window shared by splines on the same control points (and a
    # collinear set with its virtual point, and an affine one) keeps their
    # kernel matrices: each spline's patch, valid share and distortion
    # must be exactly those of a warp made on its own.
    from terrasynth_core.warping.thin_plate import WarpWindow, warp_distortion

    rng = np.random.default_rng(3)
    source = rng.normal(size=(120, 110)).astype(np.float32)
    line = np.array([[10.0, 10.0], [30.0, 31.0], [50.0, 49.0], [70.0, 71.0]])
    splines = [ThinPlateSpline.fit(SRC, SRC + rng.normal(scale=2.0, size=SRC.shape) + 20.0, regularization=1e-3)
               for _ in range(3)]
    splines += [ThinPlateSpline.fit(line, line + rng.normal(scale=1.0, size=line.shape) + 5.0),
                ThinPlateSpline.similarity(SRC, SRC * 1.1, reflect=True)]
    window = WarpWindow((5, 7), (41, 37))
    for tps in splines + splines:  # the second time from the window's memory
        patch, valid = window.warp(source, tps, return_valid=True)
        alone, alone_valid = warp_patch(source, tps, (5, 7), (41, 37), return_valid=True)
        assert patch.tobytes() == alone.tobytes() and valid == alone_valid
        reference = tps.transform(window.cells)
        assert window.coordinates(tps).tobytes() == reference.tobytes()
        assert window.distortion(tps) == warp_distortion(tps, (5, 7), (41, 37))
        disc = window.disc(4)
        assert window.distortion(tps) >= 1.0 and len(disc) > 0


def test_fits_on_the_same_source_points_share_their_system_and_still_interpolate():
    dst_a, dst_b = SRC + _perturbation(), SRC - 2.0 * _perturbation()
    a, b = ThinPlateSpline.fit(SRC, dst_a), ThinPlateSpline.fit(SRC.copy(), dst_b)
    assert np.abs(a.transform(SRC) - dst_a).max() < 1e-6
    assert np.abs(b.transform(SRC) - dst_b).max() < 1e-6
    assert a.control_points is b.control_points and not a.control_points.flags.writeable
    # A repeated point is refused every time, not only when first seen.
    for _ in range(2):
        with pytest.raises(ParamsError, match="coincide"):
            ThinPlateSpline.fit(np.vstack([SRC, SRC[:1]]), np.vstack([dst_a, dst_a[:1]]))


def test_a_fit_leaves_the_callers_points_its_own():
    # The spline systems are kept by their points: the kept copy is the
    # memo's, so the caller's array stays writable and a later change to
    # it (or to a buffer it views) reaches no other spline.
    buffer = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0], [5.0, 3.0]])
    src, dst = buffer[:4], buffer[:4] + 1.0
    ThinPlateSpline.fit(src, dst)
    assert src.flags.writeable
    buffer[0] = (3.0, 3.0)
    again = ThinPlateSpline.fit(np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]]), dst)
    np.testing.assert_allclose(again.transform(np.array([[0.0, 0.0]])), [[1.0, 1.0]], atol=1e-6)
