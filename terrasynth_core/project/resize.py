"""Pins and stamps follow the sketch when it changes size.

Pins and stamp centres are output cells and a stamp's footprint is in
output cells too, so when the sketch (the output grid) is resized from
``old`` to ``new`` cells they move with the terrain they mark: a cell
centre ``i`` maps to ``(i + 0.5) * new / old - 0.5``, as the sketch's own
nearest-cell resize maps it, and a stamp's footprint grows or shrinks by
the geometric mean of the two axis factors (a sketch stretched in one
axis gets a stamp of the same area share, not a distorted one).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

from ..controls.options import STAMP_SCALE_RANGE
from ..synthesis import Pin
from .specs import StampSpec

__all__ = ["resize_pins", "resize_stamps"]


def _axis(value: float, old: int, new: int) -> float:
    return (value + 0.5) * new / old - 0.5


def resize_pins(pins: Sequence[Pin], old: tuple[int, int], new: tuple[int, int]) -> list[Pin]:
    """Pins moved from an ``old`` (rows, cols) grid to a ``new`` one.

    Returns
    -------
    list of Pin
        Same heights, cells rounded and kept inside the grid; when two pins
        land on one cell (a shrink), the later one is kept, as adding a pin
        on a pinned cell does.
    """
    moved: dict[tuple[int, int], Pin] = {}
    for pin in pins:
        row = min(max(round(_axis(pin.row, old[0], new[0])), 0), new[0] - 1)
        col = min(max(round(_axis(pin.col, old[1], new[1])), 0), new[1] - 1)
        moved.pop((row, col), None)
        moved[(row, col)] = Pin(int(row), int(col), pin.height)
    return list(moved.values())


def resize_stamps(stamps: Sequence[StampSpec], old: tuple[int, int], new: tuple[int, int]) -> list[StampSpec]:
    """Stamps moved and scaled from an ``old`` (rows, cols) grid to a ``new`` one.

    Returns
    -------
    list of StampSpec
        Centres mapped like cell centres, scales times the geometric mean of
        the axis factors, within :data:`~terrasynth_core.controls.options.STAMP_SCALE_RANGE`.
    """
    factor = math.sqrt((new[0] / old[0]) * (new[1] / old[1]))
    low, high = STAMP_SCALE_RANGE
    return [dataclasses.replace(
        spec, center=(min(max(_axis(spec.center[0], old[0], new[0]), 0.0), new[0] - 1.0),
                      min(max(_axis(spec.center[1], old[1], new[1]), 0.0), new[1] - 1.0)),
        scale=min(max(spec.scale * factor, low), high)) for spec in stamps]
