"""What the water level does to the current terrain, before the next run.

The engine brings painted water below the level and warns about land below
it elsewhere (``terrasynth_core.controls.water.flooded_land``); here the
same count is made against the terrain on screen as the artist moves the
level, with its share of the map and the level that would flood no land.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from terrasynth_core.controls import Water
from terrasynth_core.controls.water import flooded_land


@dataclass(frozen=True)
class Drowning:
    """Land (not painted as water) below the water level.

    Attributes
    ----------
    cells : int
        Land cells below ``level``.
    share : float
        ``cells`` over all cells of the map, 0 to 1.
    level : float
        The water level checked, metres.
    safe_level : float
        The highest level (rounded down to 0.1 m) that leaves no land cell
        of this terrain below it.
    """

    cells: int
    share: float
    level: float
    safe_level: float

    def message(self, *, connected_only: bool = False) -> str:
        """One line for the banner; ``connected_only``: the views draw only
        water connected to the painted water."""
        head = (f"{self.share:.1%} of the map ({self.cells} land cells not painted as water) lies below the "
                f"water level {self.level:g} m")
        if connected_only:
            return head + ("; drawn dry where no painted water reaches it, but a water surface at the level "
                           "in another program would cover it.")
        return head + " and will read as water."


def drowned_land(heights: np.ndarray, water: np.ndarray, level: float) -> Drowning | None:
    """Land below the water level, or None when there is none.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        The terrain, metres.
    water : ndarray of bool, shape (rows, cols)
        Painted water.
    level : float
        Water level, metres.
    """
    cells = flooded_land(heights, Water(water, level))
    if cells == 0:
        return None
    land = heights[~water]
    safe = math.floor(float(land.min()) * 10.0) / 10.0
    return Drowning(cells, cells / heights.size, float(level), safe)


def document_drowning(document) -> Drowning | None:
    """:func:`drowned_land` for a :class:`~terrasynth_app.model.Document`'s
    painted water, level and last terrain (None without water or a terrain
    of the sketch's size)."""
    result = document.result
    if result is None or result.shape != document.output_shape or not document.sketch.has_water:
        return None
    return drowned_land(result.heights, np.asarray(document.sketch.water), document.water_level)
