"""Elevation pins: met exactly, their correction local and smooth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.controls.pins import Pin, apply_pins
from terrasynth_core.errors import ParamsError
from terrasynth_core.synthesis import Controls, Session, SynthesisParams


P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


def test_pins_are_met_and_stay_local():
    rng = np.random.default_rng(0)
    h = ndimage.gaussian_filter(rng.normal(size=(200, 200)), 3).astype(np.float32) * 100
    pins = [Pin(100, 100, 500.0), Pin(110, 120, -50.0)]
    out, errors = apply_pins(h, pins, radius=40)
    assert max(abs(e.error) for e in errors) < 1e-3
    far = np.hypot(*np.mgrid[:200, :200] - np.array([105, 110])[:, None, None]) > 70
    assert (out[far] == h[far]).all()
    # Smooth: the correction's steepest step is far below the pin's height change.
    d = out.astype(np.float64) - h
    assert np.abs(np.diff(d, axis=0)).max() < 0.1 * 550


def test_pins_in_a_run_are_under_a_percent_of_the_range(lowland):
    pins = (Pin(40, 60, 900.0), Pin(120, 200, 50.0))
    result = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(pins=pins)).run()
    span = float(np.ptp(result.heights))
    assert len(result.pin_errors) == 2
    for e in result.pin_errors:
        assert abs(e.error) < 0.01 * span
        assert result.heights[e.row, e.col] == pytest.approx(e.target, abs=1e-3)
    with pytest.raises(ParamsError, match="outside"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(pins=(Pin(400, 0, 1.0),)))
