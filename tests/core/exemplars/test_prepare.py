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
