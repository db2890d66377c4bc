"""Off-screen 3D pictures of a terrain (pyvista), for scripts and exports.

The core prepares the arrays and the camera direction
(:mod:`terrasynth_core.pictures.terrain_3d`); this module only hands them to
VTK, which the core may not import.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from terrasynth_core.pictures import camera_direction, surface_grid, trim_background


def render_terrain(heights: np.ndarray, colours: np.ndarray, *, cell_size: tuple[float, float],
                   size: tuple[int, int], exaggeration: float = 2.0, azimuth: float = -30.0,
                   elevation: float = 35.0, zoom: float = 1.3, trim: bool = False) -> np.ndarray:
    """A 3D view of the terrain on a white background, rendered off screen.

    Parameters
    ----------
    heights : ndarray of float, shape (rows, cols)
        Metres, finite; row 0 is the northern edge.
    colours : ndarray, shape (rows, cols, 3)
        RGB from 0 to 255 of every cell, e.g. ``terrain_colours(heights)``.
    cell_size : (dy, dx)
        Metres.
    size : (width, height)
        Pixels of the picture; with ``trim`` the most it may take.
    exaggeration : float, default 2
        Vertical exaggeration.
    azimuth, elevation : float
        Camera direction: degrees from south towards east (negative = west)
        and above the horizon; the camera orbits the centre with z up.
    zoom : float, default 1.3
        Zoom after fitting the terrain into the view.
    trim : bool, default False
        Cut the white margin and keep the terrain's own aspect.

    Returns
    -------
    ndarray of uint8, shape (height, width, 3)
        Smaller than ``size`` on one side when trimmed.
    """
    import pyvista as pv

    pv.OFF_SCREEN = True
    rows, cols = heights.shape
    z, rgb = surface_grid(heights, colours)
    grid = pv.ImageData(dimensions=(cols, rows, 1), spacing=(cell_size[1], cell_size[0], 1.0))
    grid.point_data["z"] = z
    grid.point_data["colour"] = rgb
    surface = grid.warp_by_scalar("z", factor=exaggeration)
    # Render at twice the size and shrink: cheap anti-aliasing.
    plotter = pv.Plotter(off_screen=True, window_size=(2 * size[0], 2 * size[1]))
    try:
        plotter.set_background("white")
        plotter.add_mesh(surface, scalars="colour", rgb=True, smooth_shading=True, show_scalar_bar=False)
        centre = np.array(surface.center)
        x0, x1, y0, y1, _, _ = surface.bounds
        eye = centre + 2.0 * max(x1 - x0, y1 - y0) * camera_direction(azimuth, elevation)
        plotter.camera_position = [tuple(eye), tuple(centre), (0.0, 0.0, 1.0)]
        plotter.reset_camera()
        plotter.camera.zoom(zoom)
        shot = plotter.screenshot(None, return_img=True)[:, :, :3]
    finally:
        plotter.close()
    if trim:
        shot = trim_background(shot)
    f = min(size[0] / shot.shape[1], size[1] / shot.shape[0])
    fitted = (max(1, round(shot.shape[1] * f)), max(1, round(shot.shape[0] * f)))
    return np.asarray(Image.fromarray(shot).resize(fitted, Image.LANCZOS))
