"""The event generators a worker drains, with stand-in requests (no synthesis)."""

import threading

import pytest

from terrasynth_core.errors import ParamsError, SynthesisCancelled
from terrasynth_app.model import VariationMade, variation_events


class _Batch:
    """Stands in for a SynthesisRequest: ``make_variations`` reports each
    seed's "terrain" (the seed doubled) and polls ``cancel``."""

    def __init__(self, gate=None, error=None):
        self.gate = gate
        self.error = error
        self.stopped = threading.Event()

    def make_variations(self, seeds, *, progress, cancel):
        for index, seed in enumerate(seeds):
            if self.error is not None:
                raise self.error
            progress(index, 2 * seed)
            if self.gate is not None:
                while not self.gate.wait(0.01):
                    if cancel():
                        self.stopped.set()
                        raise SynthesisCancelled("variations cancelled")
        return [2 * seed for seed in seeds]


def _drain(events):
    items = []
    while True:
        try:
            item = next(events)
        except StopIteration as stop:
            return items, stop.value
        if item is not None:
            items.append(item)


def test_variations_come_one_by_one_then_all_in_seed_order():
    items, value = _drain(variation_events(_Batch(), [5, 7, 9], poll_seconds=0.01))
    assert [(v.index, v.terrain) for v in items] == [(0, 10), (1, 14), (2, 18)]
    assert all(isinstance(v, VariationMade) for v in items)
    assert value == [10, 14, 18]


def test_an_error_of_the_batch_is_raised_by_the_generator():
    with pytest.raises(ParamsError, match="bad seeds"):
        _drain(variation_events(_Batch(error=ParamsError("bad seeds")), [1], poll_seconds=0.01))


def test_closing_the_generator_stops_the_batch():
    batch = _Batch(gate=threading.Event())
    events = variation_events(batch, [1, 2, 3], poll_seconds=0.01)
    first = next(item for item in events if item is not None)
    assert first.index == 0
    events.close()  # what a cancelled worker does at its next checkpoint
    assert batch.stopped.is_set()
