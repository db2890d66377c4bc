"""Terrain measures: slope, TPI, feature scores."""

import math

import numpy as np
import pytest

from terrasynth_core import ParamsError
from terrasynth_core.measures import feature_tpi_score, slope, topographic_position_index
from terrasynth_core.features import FeatureGraph, extract_features
from terrasynth_core.io import load_dem


def _plane(d_drow: float, d_dcol: float, shape=(40, 50)) -> np.ndarray:
    rr, cc = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float32)
    return (d_drow * rr + d_dcol * cc).astype(np.float32)


# -- slope -------------------------------------------------------------------
def test_slope_of_a_plane():
    z = _plane(0, 15)  # 15 m per 30 m cell = 0.5
    s = slope(z, cell_size=30)
    np.testing.assert_allclose(s, math.degrees(math.atan(0.5)), atol=1e-4)
    z[3, 3] = np.nan
    assert np.isnan(slope(z, cell_size=30)[3, 3]) and not np.isnan(slope(z, cell_size=30)[3, 4])


# -- TPI ---------------------------------------------------------------------
def test_tpi_matches_a_direct_mean():
    rng = np.random.default_rng(2)
    z = rng.normal(500, 80, (50, 60)).astype(np.float32)
    z[10:14, 10:14] = np.nan
    tpi = topographic_position_index(z, radius=4)
    assert tpi.dtype == np.float32
    for r, c in [(25, 30), (2, 3), (15, 12), (49, 59)]:
        rr, cc = np.mgrid[0:50, 0:60]
        d = np.hypot(rr - r, cc - c)
        ring = (d <= 4) & (d > 0) & ~np.isnan(z)
        assert tpi[r, c] == pytest.approx(z[r, c] - z[ring].mean(), abs=1e-2)
    assert np.isnan(tpi[11, 11])


def test_tpi_annulus_and_signs():
    z = np.zeros((41, 41), np.float32)
    z[20, 20] = 10
    tpi = topographic_position_index(z, radius=5, inner_radius=2)
    assert tpi[20, 20] == pytest.approx(10)
    assert topographic_position_index(-z, radius=5)[20, 20] < 0
    np.testing.assert_allclose(topographic_position_index(np.full((20, 20), 7.0), radius=3), 0, atol=1e-5)
    with pytest.raises(ParamsError, match="radius"):
        topographic_position_index(z, radius=0.5)
    with pytest.raises(ParamsError, match="inner_radius"):
        topographic_position_index(z, radius=3, inner_radius=3)


# -- feature scores ----------------------------------------------------------
def test_feature_tpi_score_signs_on_synthetic_terrain():
    cols = np.arange(120, dtype=np.float32)
    z = np.repeat(100 * np.sin(cols / 5)[None, :], 80, axis=0)
    maps = extract_features(z)
    assert feature_tpi_score(z, maps.ridges, radius=10) > 1.0
    assert feature_tpi_score(z, maps.valleys, radius=10) < -1.0
    empty = FeatureGraph("ridge", z.shape, (), ())
    assert math.isnan(feature_tpi_score(z, empty, radius=10))
    with pytest.raises(ParamsError, match="shape"):
        feature_tpi_score(z[:40], maps.ridges, radius=10)


def test_feature_tpi_score_on_a_real_dem_with_nodata(dems_dir):
    field = load_dem(dems_dir / "Mandakini.bil")
    maps = extract_features(field)
    assert feature_tpi_score(field, maps.ridges, radius=12) > 0.7
    assert feature_tpi_score(field, maps.valleys, radius=12) < -0.7
