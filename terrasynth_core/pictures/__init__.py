"""Pictures of terrain, shared by the CLI, the app and the scripts.

* :mod:`.shading`: :func:`hillshade`, :func:`grey_hillshade` and :func:`lit`
  (colours under a hillshade);
* :mod:`.colours`: the one height colour ramp (:func:`terrain_colours`),
  :func:`shaded_relief`, thumbnails and :func:`patch_colours`;
* :mod:`.water`: water below a level, blue by depth, with its shoreline;
* :mod:`.overlay`: ridges and valleys over a hillshade;
* :mod:`.terrain_3d`: arrays and camera for 3D views (the renderer itself
  lives outside the core, in ``terrasynth_app.views.render_3d``);
* :mod:`.masks`: :func:`mask_picture` (masks and splat maps as RGB);
* :mod:`.files`: :func:`save_png`;
* :mod:`.sheet`: :func:`compose` (labelled panels in a grid) and :func:`fit_panel`.

The pictures only read the engine's results; no synthesis stage imports them.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .colours import (TERRAIN_LUT, height_range, height_ticks, patch_colours, ramp_strip, ringed,
        shaded_relief, shaded_window, terrain_colours, thumbnail)
    from .files import save_png
    from .masks import BAND_COLOURS, mask_picture
    from .overlay import RIDGE_COLOUR, VALLEY_COLOUR, render_overlay
    from .shading import grey_hillshade, hillshade, lit
    from .sheet import compose, fit_panel
    from .terrain_3d import camera_direction, surface_grid, trim_background
    from .water import DEEP_RGB, SHALLOW_RGB, SHORE_RGB, depth_colours, water_cells, water_rgba

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".colours": (
        "TERRAIN_LUT", "height_range", "height_ticks", "patch_colours", "ramp_strip", "ringed", "shaded_relief",
        "shaded_window", "terrain_colours", "thumbnail"
    ),
    ".files": ("save_png",),
    ".masks": ("BAND_COLOURS", "mask_picture"),
    ".overlay": ("RIDGE_COLOUR", "VALLEY_COLOUR", "render_overlay"),
    ".shading": ("grey_hillshade", "hillshade", "lit"),
    ".sheet": ("compose", "fit_panel"),
    ".terrain_3d": ("camera_direction", "surface_grid", "trim_background"),
    ".water": ("DEEP_RGB", "SHALLOW_RGB", "SHORE_RGB", "depth_colours", "water_cells", "water_rgba"),
})
