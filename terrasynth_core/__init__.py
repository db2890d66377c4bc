"""TerraSynth core: example-based terrain synthesis from real elevation data.

No Qt here: the core is plain numpy/scipy and usable from scripts and
notebooks.  See :mod:`terrasynth_core.io` for DEM files and
:mod:`terrasynth_core.features` for ridge and valley extraction.

:class:`HeightField` and :class:`GeoReference` load on first use
(:mod:`._lazy`), so ``import terrasynth_core`` costs no numpy or scipy.
"""

from typing import TYPE_CHECKING

from ._lazy import lazy_exports

if TYPE_CHECKING:
    from .errors import DEMFormatError, ParamsError, SketchError, SynthesisCancelled, TerraSynthError
    from .heightfield import GeoReference, HeightField

__version__ = "0.1.0"

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".errors": ("DEMFormatError", "ParamsError", "SketchError", "SynthesisCancelled", "TerraSynthError"),
    ".heightfield": ("GeoReference", "HeightField"),
})
