"""One square cell size per run: chosen from the examples (or asked for),
every example resampled to it once, carried by the result."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.errors import ParamsError
from terrasynth_core.exemplars import cache, ground
from terrasynth_core.heightfield import GeoReference, HeightField
from terrasynth_core.synthesis import Controls, Session, Stamp, Style, SynthesisParams

PARAMS = dict(patch_size=32, k=2, seed=0)
SHAPE = (96, 96)


def _terrain(shape, seed=0, relief=300.0, smooth=4.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    h = ndimage.gaussian_filter(rng.normal(size=shape), smooth)
    return (h / h.std() * relief + 1000).astype(np.float32)


def _field(cell, shape=(200, 200), seed=0, **kw) -> HeightField:
    return HeightField(_terrain(shape, seed), cell_size=None if cell is None else (cell, cell),
                       source=f"ex{seed}", **kw)


def test_a_geographic_example_gives_square_cells_at_its_finer_side(white_mountains):
    session = Session([white_mountains], None, shape=SHAPE, params=SynthesisParams(**PARAMS))
    dy, dx = white_mountains.cell_size
    assert session.cell_size == pytest.approx(dx)
    rows, cols = session.examples[0].heights.shape
    # 93 m rows become about 1.4 x as many 66 m rows; columns stay (less the warp's edges).
    assert rows / cols == pytest.approx(dy / dx, rel=0.05)
    result = session.run()
    assert result.cell_size == pytest.approx(dx)
    assert result.report()["cell_size"] == pytest.approx(dx)
    assert not any("up-sampled" in w for w in result.warnings)


def test_examples_at_30_and_90_m_meet_at_the_finest_and_the_coarse_one_is_named():
    fine, coarse = _field(30.0, seed=1), _field(90.0, seed=2)
    session = Session([fine, coarse], None, shape=SHAPE, params=SynthesisParams(**PARAMS))
    assert session.cell_size == 30.0
    assert session.examples[0].heights.shape == (200, 200)
    assert session.examples[1].heights.shape == (600, 600)
    notes = [w for w in session.warnings if "up-sampled" in w]
    assert len(notes) == 1 and "ex2" in notes[0] and "3.0x" in notes[0] and "--cell-size" in notes[0]


def test_an_asked_cell_size_wins_and_coarsens():
    session = Session([_field(30.0, seed=1)], None, shape=SHAPE, params=SynthesisParams(cell_size=60, **PARAMS))
    assert session.cell_size == 60.0
    assert session.examples[0].heights.shape == (100, 100)


def test_examples_without_cell_size_are_taken_at_the_run_cell_size():
    session = Session([_field(None, seed=1), _field(45.0, seed=2)], None, shape=SHAPE,
                      params=SynthesisParams(**PARAMS))
    assert session.cell_size == 45.0
    assert [e.heights.shape for e in session.examples] == [(200, 200), (200, 200)]


def test_no_cell_size_anywhere_keeps_cells_and_says_so_once():
    arrays = [_terrain((200, 200), 1), _terrain((200, 200), 2)]
    result = Session(arrays, None, shape=SHAPE, params=SynthesisParams(**PARAMS)).run()
    assert result.cell_size is None
    assert sum("cell size is unknown" in w for w in result.warnings) == 1


def test_square_examples_at_the_run_size_give_the_same_bytes_as_arrays():
    heights = _terrain((200, 200), 3)
    with_cells = Session([HeightField(heights, cell_size=(30.0, 30.0))], None, shape=SHAPE,
                         params=SynthesisParams(**PARAMS)).run()
    plain = Session([heights], None, shape=SHAPE, params=SynthesisParams(**PARAMS)).run()
    assert with_cells.heights.tobytes() == plain.heights.tobytes()


def test_styles_and_stamps_count_for_the_cell_size():
    labels = np.zeros(SHAPE, np.int16)
    labels[:, 48:] = 1
    controls = Controls(styles=(Style(_field(60.0, seed=1)), Style(_field(90.0, seed=2))), style_map=labels,
                        stamps=(Stamp(_field(20.0, shape=(60, 60), seed=3), (48, 48)),))
    session = Session([], None, shape=SHAPE, params=SynthesisParams(**PARAMS), controls=controls)
    assert session.cell_size == 20.0
    # The stamp keeps its true size: 60 cells of 20 m.
    r0, r1, c0, c1 = session.layout.stamps[0].bbox
    assert 58 <= r1 - r0 <= 62 and 58 <= c1 - c0 <= 62
    assert sum("up-sampled" in w for w in session.warnings) == 2


def test_an_example_too_small_after_resampling_gets_the_usual_error():
    small = _field(10.0, shape=(100, 100), seed=1)
    with pytest.raises(ParamsError, match="smaller than a patch"):
        Session([small], None, shape=SHAPE, params=SynthesisParams(cell_size=40, **PARAMS))


def test_a_cell_size_that_would_blow_up_or_crush_the_example_is_refused_with_what_works(white_mountains):
    # At 1 m cells this corner would be 37065 x 26437 cells, 3.9 GB as
    # float32 (the whole tile, 33 GB: it was a MemoryError traceback); at
    # 1e5 m, nothing.  The cell sizes suggested are rounded so that they pass.
    with pytest.raises(ParamsError, match=r"N44W072.*37065x26437 cells.*at least 3\.92 m \(--cell-size\)"):
        Session([white_mountains], None, shape=SHAPE, params=SynthesisParams(cell_size=1, **PARAMS))
    with pytest.raises(ParamsError, match=r"N44W072.*0\.4x0\.3 cells, too few.*at most 13200 m"):
        Session([white_mountains], None, shape=SHAPE, params=SynthesisParams(cell_size=1e5, **PARAMS))


@pytest.mark.parametrize("bad", [0, -5.0, float("nan"), float("inf"), "30", True])
def test_bad_cell_size_is_named(bad):
    with pytest.raises(ParamsError, match="cell_size"):
        SynthesisParams(cell_size=bad)


def test_the_resampled_grid_is_memoised_and_cached_on_disk(monkeypatch):
    field = HeightField(_terrain((120, 120), 4), cell_size=(0.1 / 1200 * 111_000, 0.1 / 1200 * 80_000),
                        georef=GeoReference(10.0, 45.1, 0.1 / 1200, 0.1 / 1200, 4326), source="geo")
    first, _ = ground.on_ground(field, 7.0, name="geo")
    assert first.cell_size == (7.0, 7.0) and first.nodata_count == 0
    ground._MEMO.clear()
    calls = []
    monkeypatch.setattr(ground, "to_square_cells", lambda *a: calls.append(a))
    again, _ = ground.on_ground(field, 7.0, name="geo")
    assert not calls  # read back from the disk cache, not warped again
    assert np.array_equal(again.heights, first.heights)
    assert any(p.name.startswith(f"example-v{cache.CACHE_VERSION}-ground-") for p in cache.cache_dir().iterdir())
