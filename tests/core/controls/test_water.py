"""Water: below its level, smooth banks, locked cells untouched."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from terrasynth_core.controls.water import Water, apply_water
from terrasynth_core.synthesis import Controls, Session, SynthesisParams


P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


def test_water_is_below_the_level_and_the_banks_are_smooth(lowland):
    mask = np.zeros(SHAPE, bool)
    mask[:, :30] = True  # a sea
    mask[78:83, 30:200] = True  # a river
    level = float(np.median(lowland.heights))
    result = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(water=Water(mask, level))).run()
    h = result.heights
    assert (h[mask] < level).all()
    shore = ndimage.binary_dilation(mask) & ~mask
    assert (h[shore] >= level).all()
    # No wall at the shore: the step across it is small against the relief.
    step = np.abs(np.diff(h, axis=1))[:, 28:32].max()
    assert step < 0.2 * np.ptp(lowland.heights)


def test_a_map_all_under_water_is_said_to_be(lowland):
    # An all-dark (or inverted) mask made a flat sheet of water, silently.
    level = float(np.median(lowland.heights))
    whole = Session([lowland], None, shape=SHAPE, params=P,
                    controls=Controls(water=Water(np.ones(SHAPE, bool), level))).run()
    assert any("water mask covers 100 % of the map" in w for w in whole.warnings)
    part = np.zeros(SHAPE, bool)
    part[:, :200] = True
    some = Session([lowland], None, shape=SHAPE, params=P, controls=Controls(water=Water(part, level))).run()
    assert not any("water mask covers" in w for w in some.warnings)


def test_water_outside_a_lock_is_untouched():
    h = np.linspace(0, 100, 100 * 100, dtype=np.float32).reshape(100, 100)
    mask = np.zeros((100, 100), bool)
    mask[40:60, 40:60] = True
    locked = np.zeros((100, 100), bool)
    locked[:, :50] = True
    out = apply_water(h, Water(mask, 10.0), bank_width=8, locked=locked)
    assert (out[locked] == h[locked]).all() and not (out[~locked] == h[~locked]).all()


def test_a_pin_near_the_shore_does_not_lift_the_water(lowland):
    from terrasynth_core.controls.pins import Pin

    mask = np.zeros(SHAPE, bool)
    mask[:, :40] = True  # a sea
    level = float(np.median(lowland.heights))
    high = float(lowland.heights.max()) + 500.0
    # One pin high on the shore, one on the water itself.
    pins = (Pin(80, 44, high), Pin(20, 10, high))
    result = Session([lowland], None, shape=SHAPE, params=P,
                     controls=Controls(water=Water(mask, level), pins=pins, pin_radius=30)).run()
    h = result.heights
    assert (h[mask] < level).all()
    assert h[80, 44] == np.float32(high)  # the shore pin is met
    assert any("pin at (20, 10) is on painted water" in w for w in result.warnings)


def test_water_beside_locked_water_still_lies_below_the_level():
    """A lake that runs on into locked terrain already shaped by it (a
    tiled run's finished neighbour): a hill freshly made inside the lake
    next to the lock does not stand out of the water, as it would if the
    shaping eased in from the locked water."""
    yy, xx = np.mgrid[0:100, 0:100].astype(float)
    lake = np.hypot(yy - 50, xx - 40) < 25
    water = Water(lake, 330.0)
    flat = np.full((100, 100), 340.0, np.float32)
    before = apply_water(flat, water, bank_width=20)  # the neighbour, finished with the lake
    locked = xx < 20
    hill = (340.0 + 150.0 * np.exp(-((yy - 50) ** 2 + (xx - 30) ** 2) / 60.0)).astype(np.float32)
    heights = np.where(locked, before, hill).astype(np.float32)
    out = apply_water(heights, water, bank_width=20, locked=locked)
    assert np.array_equal(out[locked], heights[locked])
    assert (out[lake] < 330.0).all()
    assert (heights[lake & ~locked] > 400.0).any()  # (the hill was well above it)


def test_a_bank_wider_than_the_map_is_refused_but_a_crop_keeps_the_maps_bank():
    """The bank is checked against the whole output; a re-synthesis's crop
    (smaller than the bank) keeps the whole map's bank width."""
    import pytest

    from terrasynth_core.errors import ParamsError

    mask = np.zeros((133, 133), bool)
    mask[:20] = True
    with pytest.raises(ParamsError, match=r"bank width 150 cells is wider than the 133x133 map: at most 133"):
        Controls(water=Water(mask, 0.0, None, 150.0)).checked((133, 133), 1)
    crop = Controls(water=Water(mask, 0.0, None, 150.0), previous=np.zeros((133, 133), np.float32),
                    selection=np.ones((133, 133), bool)).checked((133, 133), 1)
    assert crop.water.bank_width == 150.0
    with pytest.raises(ParamsError, match=r"water depth 1e\+06 m"):
        Controls(water=Water(mask, 0.0, 1e6, None)).checked((133, 133), 1)
