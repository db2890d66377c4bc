"""Graph-cut seams between existing terrain and a new patch."""

import dataclasses

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.errors import ParamsError
from terrasynth_core.placing.graph_cut import SeamResult, graph_cut_seam, seam_pixels

SHAPE = (40, 40)


def _terrain(seed):
    rng = np.random.default_rng(seed)
    return (ndimage.gaussian_filter(rng.normal(size=SHAPE), 2) * 200 + 800).astype(np.float32)


def _border():
    b = np.zeros(SHAPE, bool)
    b[[0, -1], :] = True
    b[:, [0, -1]] = True
    return b


def _left_overlap(width=30):
    filled = np.zeros(SHAPE, bool)
    filled[:, :width] = True
    return filled


def _cut_cost(take_new, existing, new, epsilon):
    """Independent per-edge sum of Kwatra's M over the cut edges."""
    d = np.abs(existing.astype(np.float64) - new)
    cost = 0.0
    for axis in (0, 1):
        s = [slice(None), slice(None)]
        t = [slice(None), slice(None)]
        s[axis], t[axis] = slice(None, -1), slice(1, None)
        cut = take_new[tuple(s)] != take_new[tuple(t)]
        cost += (d[tuple(s)] + d[tuple(t)] + epsilon)[cut].sum()
    return cost


def test_empty_window_takes_everything_new_without_a_graph():
    existing = np.full(SHAPE, np.nan, np.float32)
    result = graph_cut_seam(existing, _terrain(0), np.zeros(SHAPE, bool))
    assert isinstance(result, SeamResult)
    assert result.take_new.all() and not result.seam.any()
    assert result.cost == 0.0 and result.overlap_pixels == 0
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.cost = 1.0


def test_hard_constraints_and_window_rules_hold():
    existing, new = _terrain(1), _terrain(2)
    filled = np.zeros(SHAPE, bool)
    filled[:, :25] = True
    filled[:15, :] = True
    keep_new = np.zeros(SHAPE, bool)
    keep_new[5:12, 5:12] = True
    keep_new[0, 3:6] = True  # a border pixel released by the caller
    keep_existing = np.zeros(SHAPE, bool)
    keep_existing[20:30, 15:22] = True
    result = graph_cut_seam(existing, new, filled, keep_new=keep_new, keep_existing=keep_existing)

    assert result.take_new[keep_new].all()
    assert not result.take_new[keep_existing].any()
    assert result.take_new[~filled].all()
    assert not result.take_new[filled & _border() & ~keep_new].any()
    assert result.overlap_pixels == int(filled.sum())
    np.testing.assert_array_equal(result.seam, seam_pixels(result.take_new, filled))
    assert result.seam.any() and not (result.seam & ~result.take_new).any()


def test_cut_runs_where_the_windows_agree():
    existing = _terrain(3)
    new = existing.copy()
    # The overlap (columns 0-29) disagrees on its outer half, agrees on its
    # inner half next to the new patch.
    new[:, :15] += _terrain(4)[:, :15] - 700.0
    filled = _left_overlap(30)
    result = graph_cut_seam(existing, new, filled, epsilon=1e-3)

    seam_cols = np.nonzero(result.seam)[1]
    assert seam_cols.min() >= 15
    assert not result.take_new[:, :15].any()
    naive = np.zeros(SHAPE, bool)
    naive[:, 15:] = True  # straight cut through the middle of the overlap
    assert result.cost < 0.01 * _cut_cost(naive, existing, new, 1e-3)
    assert result.cost == pytest.approx(_cut_cost(result.take_new, existing, new, 1e-3), rel=1e-9)


def test_fully_filled_window_without_keep_new_keeps_existing():
    result = graph_cut_seam(_terrain(5), _terrain(6), np.ones(SHAPE, bool))
    assert not result.take_new.any()
    assert result.cost == 0.0


def test_inputs_are_not_mutated_and_unfilled_nan_is_ignored():
    existing = _terrain(7)
    existing[:, 30:] = np.nan
    new = _terrain(8)
    filled = _left_overlap(30)
    copies = [a.copy() for a in (existing, new, filled)]
    result = graph_cut_seam(existing, new, filled)
    assert np.isfinite(result.cost)
    for before, after in zip(copies, (existing, new, filled)):
        np.testing.assert_array_equal(before, after)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(keep_new=np.ones(SHAPE, bool), keep_existing=np.ones(SHAPE, bool)), "overlap"),
        (dict(keep_existing=np.ones(SHAPE, bool)), "unfilled"),
        (dict(keep_new=np.ones((3, 3), bool)), "shape"),
        (dict(epsilon=0.0), "epsilon"),
    ],
)
def test_bad_arguments_raise(kwargs, words):
    with pytest.raises(ParamsError, match=words):
        graph_cut_seam(_terrain(9), _terrain(10), _left_overlap(20), **kwargs)


def test_nan_in_a_filled_pixel_raises():
    existing = _terrain(11)
    existing[3, 3] = np.nan
    with pytest.raises(ParamsError, match="finite"):
        graph_cut_seam(existing, _terrain(12), _left_overlap(20))
