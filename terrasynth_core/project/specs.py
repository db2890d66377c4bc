"""What a project stores of the artist controls: styles and stamps by
reference, so a project names its DEMs instead of embedding them.

:class:`StyleSpec` and :class:`StampSpec` become the core's ``Style`` and
``Stamp`` (:mod:`terrasynth_core.controls`) only when a run starts
(:meth:`StyleSpec.to_core`, :meth:`StampSpec.to_core`), because that reads
the DEMs: on the app's worker thread, or in ``terrasynth-cli synth
--project``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..controls.options import check_stamp_transform
from ..errors import ParamsError
from ..features.labels import parse_colour
from ..synthesis import Stamp, Style
from .refs import ExampleRef

__all__ = ["RELIEF_SCALE_RANGE", "StampSpec", "StyleSpec"]

#: Relief scales a style may have.
RELIEF_SCALE_RANGE = (0.05, 10.0)


@dataclass(frozen=True)
class StyleSpec:
    """A painted terrain style of a document.

    Parameters
    ----------
    id : int
        Stable id (0 to 32767) the style layer stores; never reused within a
        document, so undoing old strokes never paints another style.
    name : str
    color : str
        ``"#rrggbb"``, how the style's regions are drawn.
    example : ExampleRef
        The style's example DEM.
    relief_scale : float, default 1
        Multiplies the example's height variation about its median.
    base : float or None, default None
        Level its terrain sits at, metres; None: the example's median.
    """

    id: int
    name: str
    color: str
    example: ExampleRef
    relief_scale: float = 1.0
    base: float | None = None

    def __post_init__(self):
        if not 0 <= int(self.id) <= np.iinfo(np.int16).max:
            raise ParamsError(f"style id {self.id}: expected 0 to {np.iinfo(np.int16).max}")
        r, g, b = parse_colour(self.color)
        object.__setattr__(self, "color", f"#{r:02x}{g:02x}{b:02x}")
        lo, hi = RELIEF_SCALE_RANGE
        if not (math.isfinite(self.relief_scale) and lo <= self.relief_scale <= hi):
            raise ParamsError(f"style {self.name!r}: relief scale {self.relief_scale}: expected {lo} to {hi}")
        if self.base is not None and not math.isfinite(self.base):
            raise ParamsError(f"style {self.name!r}: base height must be finite, got {self.base}")
        object.__setattr__(self, "relief_scale", float(self.relief_scale))
        object.__setattr__(self, "base", None if self.base is None else float(self.base))

    @property
    def rgb(self) -> tuple[int, int, int]:
        return parse_colour(self.color)

    def to_core(self) -> Style:
        """The core style, its example read (slow: call off the GUI thread)."""
        return Style(self.example.load(), relief_scale=self.relief_scale, base=self.base, name=self.name)

    def to_dict(self) -> dict:
        return {"id": self.id, "name": self.name, "color": self.color, "example": self.example.to_dict(),
                "relief_scale": self.relief_scale, "base": self.base}

    @classmethod
    def from_dict(cls, data: dict, example: ExampleRef | None = None) -> "StyleSpec":
        """Inverse of :meth:`to_dict`; ``example`` overrides the stored one
        (a project resolves relative paths itself)."""
        return cls(int(data["id"]), str(data.get("name", "")), str(data["color"]),
                   example if example is not None else ExampleRef.from_dict(data["example"]),
                   float(data.get("relief_scale", 1.0)),
                   None if data.get("base") is None else float(data["base"]))


@dataclass(frozen=True)
class StampSpec:
    """A DEM placed as it is, as a document stores it.

    Parameters
    ----------
    example : ExampleRef
        The DEM (its crop is the window used).
    center : (row, col)
        Output cell of the stamp's centre.
    source_shape : (rows, cols)
        Cells of the DEM window, for drawing the footprint without reading it.
    rotation : float, default 0
        Degrees, counter-clockwise on screen.
    scale : float, default 1
        Footprint scale (heights are not scaled).
    """

    example: ExampleRef
    center: tuple[float, float]
    source_shape: tuple[int, int]
    rotation: float = 0.0
    scale: float = 1.0

    def __post_init__(self):
        r, c = (float(v) for v in self.center)
        rows, cols = (int(v) for v in self.source_shape)
        if not (math.isfinite(r) and math.isfinite(c)):
            raise ParamsError(f"stamp centre {self.center} must be finite")
        if rows < 1 or cols < 1:
            raise ParamsError(f"stamp source shape {self.source_shape} must be positive")
        check_stamp_transform(self.scale, self.rotation)
        object.__setattr__(self, "center", (r, c))
        object.__setattr__(self, "source_shape", (rows, cols))
        object.__setattr__(self, "rotation", float(self.rotation))
        object.__setattr__(self, "scale", float(self.scale))

    def to_core(self) -> Stamp:
        """The core stamp, its DEM read (slow: call off the GUI thread)."""
        return Stamp(self.example.load(), self.center, rotation=self.rotation, scale=self.scale)

    def footprint(self, cell_size: float | None = None) -> np.ndarray:
        """Corners of the rotated, scaled window on the output grid.

        Parameters
        ----------
        cell_size : float or None
            The run's square cell size in metres: the window is drawn at
            its true size on it (when its DEM is loaded and knows its cell
            size), times ``scale``, as the core places it.

        Returns
        -------
        ndarray of float, shape (5, 2)
            ``(row, col)`` of the four corners, the first repeated last (a
            closed outline).  Uses the core's convention: counter-clockwise
            on screen, rows pointing down.
        """
        dy, dx = self.example.loaded_cell_size() or (cell_size, cell_size)
        true_h, true_w = (1.0, 1.0) if cell_size is None or dy is None else (dy / cell_size, dx / cell_size)
        half_h = 0.5 * self.source_shape[0] * self.scale * true_h
        half_w = 0.5 * self.source_shape[1] * self.scale * true_w
        theta = math.radians(self.rotation)
        cos, sin = math.cos(theta), math.sin(theta)
        a = np.array([-half_h, -half_h, half_h, half_h, -half_h])
        b = np.array([-half_w, half_w, half_w, -half_w, -half_w])
        # Source offset (a, b) -> output offset: the inverse of the core's
        # output-to-source mapping.
        rows = self.center[0] + a * cos - b * sin
        cols = self.center[1] + a * sin + b * cos
        return np.stack([rows, cols], axis=1)

    def to_dict(self) -> dict:
        return {"example": self.example.to_dict(), "center": list(self.center),
                "source_shape": list(self.source_shape), "rotation": self.rotation, "scale": self.scale}

    @classmethod
    def from_dict(cls, data: dict, example: ExampleRef | None = None) -> "StampSpec":
        """Inverse of :meth:`to_dict`; ``example`` overrides the stored one."""
        return cls(example if example is not None else ExampleRef.from_dict(data["example"]),
                   tuple(data["center"]), tuple(data["source_shape"]), float(data.get("rotation", 0.0)),
                   float(data.get("scale", 1.0)))
