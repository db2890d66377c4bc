"""The output canvas: graph cuts keep locked and protected cells, seam
solves leave locked cells bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.placing.canvas import Canvas

SHAPE = (64, 64)
P = 32


def _terrain(seed: int, level: float = 0.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return (ndimage.gaussian_filter(rng.normal(size=SHAPE), 4) * 400 + level).astype(np.float32)


def _resynthesis(blend: str = "poisson", seam: str = "cut") -> tuple[Canvas, np.ndarray, np.ndarray]:
    previous = _terrain(1, 500.0)
    selection = np.zeros(SHAPE, bool)
    selection[16:48, 16:48] = True
    canvas = Canvas(SHAPE, 50.0, patch_size=P, seam=seam, blend=blend, previous=previous, selection=selection)
    return canvas, previous, selection


def test_a_first_patch_takes_its_whole_window_at_no_cost():
    canvas = Canvas(SHAPE, 50.0, patch_size=P)
    cut = canvas.cut((0, P, 0, P), _terrain(2)[:P, :P])
    assert cut.take_new.all() and not cut.seam.any() and cut.normalized_cost == 0.0


@pytest.mark.parametrize("seam", ["cut", "paste"])
def test_cuts_never_take_locked_cells(seam):
    canvas, previous, selection = _resynthesis(seam=seam)
    bbox = (8, 8 + P, 8, 8 + P)  # half inside the selection
    patch = _terrain(3, 500.0)[8:8 + P, 8:8 + P]
    everything = np.ones((P, P), bool)
    cut = canvas.cut(bbox, patch, keep_new=everything)
    locked = ~selection[8:8 + P, 8:8 + P]
    assert not cut.take_new[locked].any()
    assert cut.take_new[~locked].all()  # keep_new wins everywhere else


def test_cuts_keep_protected_cells_unless_the_new_patch_must_have_them():
    canvas = Canvas(SHAPE, 50.0, patch_size=P)
    first = _terrain(4)[:P, :P]
    centre = np.zeros((P, P), bool)
    centre[8:24, 8:24] = True
    canvas.place((0, P, 0, P), first, canvas.cut((0, P, 0, P), first), 0, protect=centre)
    canvas.blend((0, P, 0, P))
    bbox = (8, 8 + P, 8, 8 + P)
    patch = _terrain(5)[8:8 + P, 8:8 + P]
    cut = canvas.cut(bbox, patch)
    protected = canvas.protected[8:8 + P, 8:8 + P]
    assert protected.any() and not cut.take_new[protected].any()
    assert cut.normalized_cost > 0.0
    keep = np.zeros((P, P), bool)
    keep[4:12, 4:12] = True  # overlaps the protected centre
    forced = canvas.cut(bbox, patch, keep_new=keep)
    assert forced.take_new[keep].all()
    assert not forced.take_new[protected & ~keep].any()


@pytest.mark.parametrize("blend", ["poisson", "c1"])
def test_placing_and_blending_leave_locked_cells_bit_identical(blend):
    canvas, previous, selection = _resynthesis(blend)
    for n, (r, c) in enumerate([(8, 8), (24, 8), (8, 24), (24, 24)]):
        bbox = (r, r + P, c, c + P)
        patch = _terrain(10 + n, 650.0)[r:r + P, c:c + P]
        cut = canvas.cut(bbox, patch, relief=40.0)
        canvas.place(bbox, patch, cut, n)
        canvas.blend(bbox)
    heights, patch_id, seams = canvas.finish()
    assert heights[~selection].tobytes() == previous[~selection].tobytes()
    assert (patch_id[~selection] == -1).all() and (patch_id[selection] >= 0).all()
    assert not np.array_equal(heights[selection], previous[selection])
    # The solve anchors the new terrain to the locked ring around it.
    ring = ndimage.binary_dilation(selection) & ~selection
    inner = selection & ~ndimage.binary_erosion(selection)
    step = np.abs(heights[inner].mean() - heights[ring].mean())
    assert step < 0.25 * np.ptp(previous)
    assert not seams[~selection].any()


def test_blend_must_follow_place_for_the_same_window():
    canvas = Canvas(SHAPE, 50.0, patch_size=P)
    patch = _terrain(6)[:P, :P]
    canvas.place((0, P, 0, P), patch, canvas.cut((0, P, 0, P), patch), 0)
    with pytest.raises(RuntimeError, match="blend"):
        canvas.blend((0, P, 8, 8 + P))
