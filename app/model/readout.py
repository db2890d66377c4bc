"""The hover readout: what the terrain is at one cell."""

from __future__ import annotations

import numpy as np

from terrasynth_core.measures import slope


def cell_readout(document, row: int, col: int) -> str | None:
    """Row, column, height, slope, style and water depth at a cell of the
    document's terrain, as one short line.

    Parameters
    ----------
    document : Document
    row, col : int
        Output cell.

    Returns
    -------
    str or None
        E.g. ``"row 12, col 40: 523.4 m, slope 12.3°, style Himalaya"``;
        the height part is left out without a terrain of the sketch's size
        (or before the cell is synthesized); None outside the map.
    """
    rows, cols = document.output_shape
    if not (0 <= row < rows and 0 <= col < cols):
        return None
    parts = [f"row {row}, col {col}"]
    result = document.result
    if result is not None and result.shape == (rows, cols) and np.isfinite(result.heights[row, col]):
        height = float(result.heights[row, col])
        # The slope of the 3x3 window around the cell: the same central
        # differences as a slope map of the whole terrain, at a cell's cost.
        r0, c0 = max(row - 1, 0), max(col - 1, 0)
        window = result.heights[r0:row + 2, c0:col + 2]
        angle = slope(window, cell_size=result.cell_size)[row - r0, col - c0]
        parts.append(f"{height:.1f} m" + (f", slope {angle:.1f}°" if np.isfinite(angle) else ""))
        if document.sketch.has_water and height < document.water_level:
            parts.append(f"{document.water_level - height:.1f} m under water")
    style_id = int(document.sketch.style[row, col])
    if style_id >= 0:
        try:
            parts.append(f"style {document.style(style_id).name}")
        except KeyError:
            pass  # a removed style's cells fall back to the plain examples
    return ", ".join(parts[:1]) + (": " + ", ".join(parts[1:]) if len(parts) > 1 else "")
