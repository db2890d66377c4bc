"""Fill windows: the grid, the order they are filled in, region seeds."""

from __future__ import annotations

import numpy as np

from terrasynth_core.placing.windows import (
    WindowQueue,
    estimate_fill_count,
    fill_windows,
    patch_window,
    region_seeds,
)


def test_the_grid_overlaps_and_ends_flush_with_the_edges():
    windows = fill_windows(np.zeros((100, 130), bool), 32, overlap=8)
    rows = sorted({w[0] for w in windows})
    cols = sorted({w[2] for w in windows})
    assert rows == [0, 24, 48, 68] and cols == [0, 24, 48, 72, 96, 98]
    assert all(r1 - r0 == 32 and c1 - c0 == 32 for r0, r1, c0, c1 in windows)
    assert windows[0] == (0, 32, 0, 32) and windows[-1] == (68, 100, 98, 130)
    assert estimate_fill_count((100, 130), 32, overlap=8, n_features=0) == len(windows)


def test_full_windows_are_left_out_and_the_estimate_follows_a_selection():
    filled = np.zeros((64, 64), bool)
    filled[:32, :32] = True
    assert (0, 32, 0, 32) not in fill_windows(filled, 32, overlap=8)
    selection = np.zeros((64, 64), bool)
    selection[:16] = True
    full = estimate_fill_count((64, 64), 32, overlap=8, n_features=0)
    assert full == 9
    assert estimate_fill_count((64, 64), 32, overlap=8, n_features=4) == 7
    assert estimate_fill_count((64, 64), 32, overlap=8, n_features=0, selection=selection) == 3 + 4


def test_the_queue_takes_the_most_filled_window_first_and_drops_full_ones():
    filled = np.zeros((64, 64), bool)
    windows = fill_windows(filled, 32, overlap=16)  # a 3x3 grid, step 16
    filled[40:64, 40:64] = True  # a feature patch near the bottom-right corner
    queue = WindowQueue(windows, filled)
    popped = []
    while True:
        share = {w: filled[w[0]:w[1], w[2]:w[3]].mean() for w in windows if w not in popped}
        w = queue.pop()
        if w is None:
            break
        # The most filled window left, the first in grid order among equals.
        best = max(v for v in share.values() if v < 1.0)
        assert share[w] == best and w == next(k for k, v in share.items() if v == best)
        popped.append(w)
        filled[w[0]:w[1], w[2]:w[3]] = True
        queue.update(w)
        if len(popped) == 1:
            filled[0:32, 0:48] = True  # a stamp, say, covers two windows
            queue.update((0, 32, 0, 48))
    assert popped[0] == (32, 64, 32, 64)
    assert filled.all()
    # Windows filled meanwhile are never handed out.
    assert (0, 32, 0, 32) not in popped and (0, 32, 16, 48) not in popped
    assert len(popped) == len(windows) - 2


def test_a_sliver_of_empty_cells_other_windows_hold_places_no_patch_of_its_own():
    """A live stroke's crop: the kept terrain around a selection leaves the
    windows along its edge a few empty cells, which the windows further in
    hold too; those windows fill them, and the edge windows are dropped."""
    filled = np.ones((160, 160), bool)
    filled[40:120, 30:130] = False  # the selection
    empty = ~filled
    windows = fill_windows(filled, 32, overlap=12)
    count = np.zeros(filled.shape, int)
    for r0, r1, c0, c1 in windows:
        count[r0:r1, c0:c1] += 1
    slivers = [w for w in windows if not ((count[w[0]:w[1], w[2]:w[3]] == 1) & empty[w[0]:w[1], w[2]:w[3]]).any()]
    assert slivers

    def fill(defer: bool) -> list:
        mask = ~empty
        queue = WindowQueue(windows, mask, defer_shared=defer)
        popped = []
        while (w := queue.pop()) is not None:
            popped.append(w)
            mask[w[0]:w[1], w[2]:w[3]] = True
            queue.update(w)
        assert mask.all()
        return popped

    deferred = fill(True)
    assert not set(slivers) & set(deferred)
    assert len(deferred) == len(windows) - len(slivers)
    assert set(slivers) & set(fill(False))  # the most filled first: slivers among them


def test_a_patch_window_is_clipped_at_the_edges():
    assert patch_window((40.0, 40.0), 32, (100, 100)) == (24, 56, 24, 56)
    assert patch_window((5.0, 95.0), 32, (100, 100)) == (0, 21, 79, 100)


def test_an_empty_region_is_seeded_from_the_window_most_inside_it():
    groups = np.zeros((96, 96), np.int16)
    groups[:, 64:] = 1
    filled = np.zeros((96, 96), bool)
    filled[:, :40] = True  # region 0 has terrain already
    windows = fill_windows(filled, 32, overlap=8)
    seeds = region_seeds(groups, filled, windows)
    assert [g for g, _ in seeds] == [1]
    r0, r1, c0, c1 = seeds[0][1]
    assert c0 >= 64 and r0 == 24  # all inside region 1, nearest its centre row
    assert region_seeds(np.zeros((96, 96), np.int16), np.zeros((96, 96), bool), windows) == []


def test_a_wave_takes_windows_that_do_not_read_each_other():
    filled = np.zeros((200, 200), bool)
    filled[90:110, :] = True  # a filled band: many windows equally constrained
    windows = fill_windows(filled, 32, overlap=8)
    queue = WindowQueue(windows, filled)
    wave = queue.pop_wave(4)
    assert len(wave) == 4
    # The first is what pop() would give; the others are as constrained.
    assert wave[0] == WindowQueue(windows, filled).pop()
    for i, (r0, r1, c0, c1) in enumerate(wave):
        for s0, s1, d0, d1 in wave[i + 1:]:
            # Window plus its one-cell ring never touches another window.
            assert not (r0 - 1 < s1 and r1 + 1 > s0 and c0 - 1 < d1 and c1 + 1 > d0)
        assert filled[r0:r1, c0:c1].mean() >= 0.5 * filled[slice(*wave[0][:2]), slice(*wave[0][2:])].mean()
    # Nothing is handed out twice, and empty windows never join a wave.
    seen = set(wave)
    while rest := queue.pop_wave(4):
        assert not seen & set(rest)
        seen |= set(rest)
        for r0, r1, c0, c1 in rest[1:]:
            assert filled[r0:r1, c0:c1].any()
