"""Renderer-ready outputs: heightmaps for engines and DCC tools, masks (splat maps).

* :mod:`.engines`: :func:`export_for_engine` with the :data:`PRESETS`
  (Unreal, Unity, Godot, Blender, Houdini);
* :mod:`.masks`: :func:`terrain_masks` (slope, curvature, flow, wetness,
  water, height bands, normal map);
* :mod:`.hydrology`: depression filling, D8 and flow accumulation;
* :mod:`.mask_files`: :func:`write_masks` as PNG or OpenEXR.

Imports the file formats (:mod:`terrasynth_core.io`) and the measures, never
the synthesis stages; the CLI and the app call it.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .engines import PRESETS, EngineExport, EnginePreset, export_file_for_engine, export_for_engine, preset_names
    from .mask_files import MASK_FORMATS, write_masks
    from .masks import MASK_NAMES, TerrainMasks, terrain_masks

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".engines": ("PRESETS", "EngineExport", "EnginePreset", "export_file_for_engine", "export_for_engine",
                 "preset_names"),
    ".mask_files": ("MASK_FORMATS", "write_masks"),
    ".masks": ("MASK_NAMES", "TerrainMasks", "terrain_masks"),
})
