"""The level field: each region's base, blurred across borders, bent
through the pins."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.controls.levels import LEVEL_SIGMA, level_field, steer_level
from terrasynth_core.controls.pins import Pin


def _halves(shape=(64, 256)) -> np.ndarray:
    groups = np.zeros(shape, np.int16)
    groups[:, shape[1] // 2:] = 1
    return groups


def test_one_base_everywhere_is_the_base_exactly():
    groups = _halves()
    level = level_field(groups, np.array([250.0, 250.0]), 32)
    assert level.dtype == np.float32 and (level == np.float32(250.0)).all()


def test_each_region_sits_at_its_base_and_the_border_is_a_smooth_ramp():
    groups = _halves()
    patch = 16
    level = level_field(groups, np.array([100.0, 900.0]), patch)
    reach = int(4 * LEVEL_SIGMA * patch)  # four standard deviations
    np.testing.assert_allclose(level[:, :128 - reach], 100.0, atol=0.05)
    np.testing.assert_allclose(level[:, 128 + reach:], 900.0, atol=0.05)
    row = level[32].astype(np.float64)
    assert (np.diff(row) >= 0).all()
    assert row[127] == pytest.approx(500.0, abs=25.0) and row[128] == pytest.approx(500.0, abs=25.0)
    # No cliff: the steepest step is about the Gaussian's peak slope.
    peak = 800.0 / (np.sqrt(2 * np.pi) * LEVEL_SIGMA * patch)
    assert np.diff(row).max() == pytest.approx(peak, rel=0.05)


def test_three_regions_take_their_bases_by_label():
    groups = np.zeros((96, 96), np.int16)
    groups[:, 32:64] = 2
    groups[:, 64:] = 1
    level = level_field(groups, np.array([0.0, 50.0, 20.0]), 8)
    assert level[48, 2] == pytest.approx(0.0, abs=0.01)
    assert level[48, 48] == pytest.approx(20.0, abs=0.01)
    assert level[48, 93] == pytest.approx(50.0, abs=0.01)


def test_pins_bend_the_level_field_locally():
    level = level_field(_halves((128, 256)), np.array([100.0, 300.0]), 32)
    pins = [Pin(48, 64, 700.0)]
    bent = steer_level(level, pins, 32)
    assert bent[48, 64] == pytest.approx(700.0, abs=0.05)
    change = bent.astype(np.float64) - level
    assert change[48, 70] > change[48, 90] > 0.0
    far = np.hypot(*np.mgrid[:128, :256] - np.array([48, 64])[:, None, None]) > 2.0 * 32 + 4
    assert bent[far].tobytes() == level[far].tobytes()
    assert steer_level(level, (), 32) is level
