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

from .engines import PRESETS, EngineExport, EnginePreset, export_for_engine, preset_names
from .mask_files import MASK_FORMATS, write_masks
from .masks import MASK_NAMES, TerrainMasks, terrain_masks

__all__ = ["MASK_FORMATS", "MASK_NAMES", "PRESETS", "EngineExport", "EnginePreset", "TerrainMasks",
           "export_for_engine", "preset_names", "terrain_masks", "write_masks"]
