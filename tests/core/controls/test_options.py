"""Validation of the controls: errors name the problem."""

from __future__ import annotations

import numpy as np
import pytest

from terrasynth_core.errors import ParamsError
from terrasynth_core.synthesis import Controls, Session, Stamp, Style, SynthesisParams


P = SynthesisParams(patch_size=32, k=2, seed=5)
SHAPE = (160, 240)


def test_style_map_errors_name_the_problem(lowland):
    bad = np.full(SHAPE, 3, np.int16)
    with pytest.raises(ParamsError, match="label 3"):
        Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland),), style_map=bad))
    with pytest.raises(ParamsError, match="no style and no default example"):
        Session([], None, shape=SHAPE, params=P,
                controls=Controls(styles=(Style(lowland),), style_map=np.full(SHAPE, -1, np.int16)))
    with pytest.raises(ParamsError, match="aspect ratio"):
        Session([], None, shape=SHAPE, params=P,
                controls=Controls(styles=(Style(lowland),), style_map=np.zeros((100, 100), np.int16)))
    with pytest.raises(ParamsError, match="relief scale"):
        Session([], None, shape=SHAPE, params=P, controls=Controls(styles=(Style(lowland, relief_scale=0),)))


def test_resynthesis_needs_both_parts(lowland):
    with pytest.raises(ParamsError, match="both"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(selection=np.ones(SHAPE, bool)))
    with pytest.raises(ParamsError, match="empty"):
        Session([lowland], None, shape=SHAPE, params=P,
                controls=Controls(previous=np.zeros(SHAPE, np.float32), selection=np.zeros(SHAPE, bool)))


def test_stamp_outside_the_output_is_refused(lowland, helens):
    with pytest.raises(ParamsError, match="outside"):
        Session([lowland], None, shape=SHAPE, params=P, controls=Controls(stamps=(Stamp(helens, (500, 20)),)))
