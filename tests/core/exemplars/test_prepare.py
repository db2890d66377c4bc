"""Example analysis: the overlapped parts (TPI beside PPA, the two
networks' samples on two threads) give what they give one after another."""

import numpy as np
import pytest

from terrasynth_core.exemplars import prepare
from terrasynth_core.features import extract_features


@pytest.mark.parametrize("threads", [True, False])
def test_analysis_is_its_parts_in_turn(white_mountains, threads, monkeypatch):
    monkeypatch.setattr(prepare, "spare_core", lambda: threads)
    heights = np.ascontiguousarray(white_mountains.heights, dtype=np.float32)
    features, samples, strong, relief = prepare._analyse(heights, 48)

    alone = extract_features(heights)
    tpi, alone_relief = prepare._tpi_and_relief(heights, 24.0, 48)
    assert relief == alone_relief > 0
    for graph, sign in ((alone.ridges, 1.0), (alone.valleys, -1.0)):
        got = features.ridges if sign > 0 else features.valleys
        assert [(n.row, n.col, n.degree) for n in got.nodes] == [(n.row, n.col, n.degree) for n in graph.nodes]
        expected = prepare._sample_pool(graph, sign, tpi, 24.0)
        assert len(samples[graph.kind]) == len(expected) > 10
        for a, b in zip(samples[graph.kind], expected):
            assert np.array_equal(a.center, b.center) and np.array_equal(a.crossings, b.crossings)
    assert strong.any()


def _with_void(field):
    """``field`` with a 60 x 120-cell void inside (an SRTM hole): the largest
    valid rectangle would keep only about 60 % of the tile."""
    h = field.heights.copy()
    h[170:230, 100:220] = np.nan
    return field.with_heights(h)


def test_voids_inside_an_example_are_filled_and_kept_out_of_samples(white_mountains):
    field = _with_void(white_mountains)
    analysis = prepare.prepare_example(field, 48, name="holed")
    assert analysis.heights.shape == field.shape and np.isfinite(analysis.heights).all()
    np.testing.assert_array_equal(analysis.valid, ~field.nodata)
    assert "holed: 7200 nodata cells" in analysis.note and "kept out of every patch" in analysis.note
    # Real heights are kept as they were.
    np.testing.assert_array_equal(analysis.heights[analysis.valid], field.heights[analysis.valid])
    # No sample's patch (and its warp margin, as at the edges) reaches the void.
    margin = int(np.ceil(24 * 1.1)) + 1
    for kind in ("ridge", "valley"):
        assert len(analysis.samples[kind]) > 10
        for s in analysis.samples[kind]:
            r, c = (int(round(v)) for v in s.center)
            assert analysis.valid[r - margin:r + margin + 1, c - margin:c + margin + 1].all()
    # The same heights without the mask are another analysis.
    plain = prepare.prepare_example(field.with_heights(analysis.heights), 48, name="filled")
    assert plain.valid is None and plain.key != analysis.key
    assert analysis.valid_values(analysis.heights).size == int(analysis.valid.sum())


def test_an_example_whose_voids_leave_no_patch_window_is_refused(white_mountains):
    h = white_mountains.heights.copy()
    for r in range(0, 400, 40):
        h[r:r + 6, :] = np.nan  # a 6-row void every 40 rows: no 52-cell window is whole
    with pytest.raises(prepare.ParamsError, match="holed has no 52x52 window without nodata"):
        prepare.prepare_example(white_mountains.with_heights(h), 48, name="holed")


def test_a_nearly_flat_example_is_named(white_mountains):
    """3 m of relief (a scaled real DEM) is said, with what would help; real
    relief is not."""
    h = white_mountains.heights
    gentle = (h - h.min()) / np.ptp(h) * 3.0 + 100.0
    note = prepare.prepare_example(white_mountains.with_heights(gentle.astype(np.float32)), 48, name="gentle").note
    assert "gentle is nearly flat (2.39 m between" in note and "relief scale" in note
    assert prepare.prepare_example(white_mountains, 48, name="real").note is None


def test_thin_voids_are_filled_and_used(white_mountains):
    """Voids within two cells of valid ground (interlaced rows, pinholes) are
    filled from their neighbours and used as terrain; a wide one in the same
    example is kept out."""
    h = white_mountains.heights.copy()
    h[100:104, 50:300] = np.nan  # 4 rows: every cell within 2 of valid ground
    h[300, 300] = np.nan
    h[200:260, 100:220] = np.nan  # wide
    analysis = prepare.prepare_example(white_mountains.with_heights(h), 48, name="holed")
    assert "holed: 1001 nodata cells filled from their neighbours" in analysis.note
    assert "holed: 7200 nodata cells" in analysis.note
    assert analysis.valid[100:104, 50:300].all() and analysis.valid[300, 300]
    assert not analysis.valid[200:260, 100:220].any() and analysis.valid.sum() == 400 * 400 - 7200


def test_voids_a_field_says_are_wide_are_kept_out_however_thin(white_mountains):
    """A landform pass's coarse blocks over an example's wide voids may be a
    cell or two across on its grid: they stay out of every patch."""
    h = white_mountains.heights.copy()
    h[100:102, 50:300] = np.nan  # thin on this grid
    plain = prepare.prepare_example(white_mountains.with_heights(h), 48, name="fine")
    assert plain.valid is None
    coarse = white_mountains.with_heights(h, metadata={prepare.WIDE_VOIDS: True})
    kept = prepare.prepare_example(coarse, 48, name="coarse")
    np.testing.assert_array_equal(kept.valid, ~np.isnan(h))
