"""What a document stores of the artist controls, and the app's helpers
for them.

:class:`StyleSpec` and :class:`StampSpec` live in the core's project
package (:mod:`terrasynth_core.project.specs`), because project files and
``terrasynth-cli synth --project`` use them too; here are the style
palette and the default stamp scale.
"""

from __future__ import annotations

from terrasynth_core.controls.options import STAMP_SCALE_RANGE
from terrasynth_core.project import RELIEF_SCALE_RANGE, StampSpec, StyleSpec

__all__ = ["RELIEF_SCALE_RANGE", "STYLE_PALETTE", "StampSpec", "StyleSpec", "fitting_scale"]

#: Colours given to new styles in turn: distinct, and none of them the
#: sketch's red, blue or white, nor the water's blue.
STYLE_PALETTE = ("#e6a10f", "#3aa655", "#b05ad6", "#d9534f", "#17a2b8", "#8c6d46", "#e377c2", "#7f7f7f")


def fitting_scale(source_shape: tuple[int, int], output_shape: tuple[int, int], *, share: float = 0.4) -> float:
    """A stamp scale at most 1 whose footprint spans ``share`` of the output's smaller side.

    Returns
    -------
    float
        Rounded to two decimals, within :data:`STAMP_SCALE_RANGE`.
    """
    scale = min(1.0, share * min(output_shape) / max(source_shape))
    return round(max(scale, STAMP_SCALE_RANGE[0]), 2)
