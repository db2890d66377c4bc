"""Pictures of terrain, shared by the CLI, the app and the scripts.

* :mod:`.shading`: :func:`hillshade`, :func:`grey_hillshade` and :func:`lit`
  (colours under a hillshade);
* :mod:`.colours`: the one height colour ramp (:func:`terrain_colours`),
  :func:`shaded_relief`, thumbnails and :func:`patch_colours`;
* :mod:`.overlay`: ridges and valleys over a hillshade;
* :mod:`.terrain_3d`: arrays and camera for 3D views (the renderer itself
  lives outside the core, in ``terrasynth_app.views.render_3d``);
* :mod:`.masks`: :func:`mask_picture` (masks and splat maps as RGB);
* :mod:`.files`: :func:`save_png`;
* :mod:`.sheet`: :func:`compose` (labelled panels in a grid) and :func:`fit_panel`.

The pictures only read the engine's results; no synthesis stage imports them.
"""

from .colours import (
    TERRAIN_LUT,
    height_range,
    patch_colours,
    shaded_relief,
    shaded_window,
    terrain_colours,
    thumbnail,
)
from .files import save_png
from .masks import BAND_COLOURS, mask_picture
from .overlay import RIDGE_COLOUR, VALLEY_COLOUR, render_overlay
from .shading import grey_hillshade, hillshade, lit
from .sheet import compose, fit_panel
from .terrain_3d import camera_direction, surface_grid, trim_background

__all__ = [
    "BAND_COLOURS",
    "mask_picture",
    "RIDGE_COLOUR",
    "TERRAIN_LUT",
    "VALLEY_COLOUR",
    "camera_direction",
    "compose",
    "fit_panel",
    "grey_hillshade",
    "height_range",
    "hillshade",
    "lit",
    "patch_colours",
    "render_overlay",
    "save_png",
    "shaded_relief",
    "shaded_window",
    "surface_grid",
    "terrain_colours",
    "thumbnail",
    "trim_background",
]
