"""World-size terrains: the output synthesized as tiles on Dask, seamless,
deterministic, resumable, streamed to a tiled GeoTIFF.

Modules: :mod:`.plan` (the tile grid, its checkerboard phases and seeds),
:mod:`.inputs` (a tile's sketch and landform windows), :mod:`.controls`
(style regions, water, stamps and pins per tile), :mod:`.library` (the
examples stored and mapped on the workers), :mod:`.tile` (one
tile's synthesis, on a worker), :mod:`.store` (finished tiles on disk),
:mod:`.output` (the streamed GeoTIFF), :mod:`.run` (the Dask run),
:mod:`.measure` (whether tile borders show).
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .plan import Tile, TilePlan, plan_tiles
    from .run import TileFinished, TiledResult, check_scheduler, run_tiled, tiled_project_inputs

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".plan": ("Tile", "TilePlan", "plan_tiles"),
    ".run": ("TileFinished", "TiledResult", "check_scheduler", "run_tiled", "tiled_project_inputs"),
})
