"""TerraSynth core: example-based terrain synthesis from real elevation data.

No Qt here: the core is plain numpy/scipy and usable from scripts and
notebooks.  See :mod:`terrasynth_core.io` for DEM files and
:mod:`terrasynth_core.features` for ridge and valley extraction.
"""

from .errors import DEMFormatError, ParamsError, SketchError, SynthesisCancelled, TerraSynthError
from .heightfield import GeoReference, HeightField

__version__ = "0.1.0"

__all__ = [
    "DEMFormatError",
    "GeoReference",
    "HeightField",
    "ParamsError",
    "SketchError",
    "SynthesisCancelled",
    "TerraSynthError",
]
