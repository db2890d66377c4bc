"""The built-in example library: real DEMs of distinct terrain styles.

The files live in the ``resources/`` folder of the repository, installed as
the package ``terrasynth_core.resources`` so that a wheel finds them too.
Their sources and licences are in ``resources/README.md``.

Anywhere a DEM path is expected (the CLI, the app), ``builtin:KEY`` names one
of these examples, e.g. ``builtin:white-mountains``.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from .errors import DEMFormatError
from .heightfield import HeightField

#: Prefix that marks a built-in example in a DEM argument.
BUILTIN_PREFIX = "builtin:"


@dataclass(frozen=True)
class BuiltinExample:
    """One example DEM shipped with TerraSynth.

    Parameters
    ----------
    key : str
        Short name used as ``builtin:KEY``.
    name : str
        Place, for people.
    style : str
        The terrain style it stands for.
    filename : str
        File under ``resources/dems``.
    source : str
        Where the data comes from.
    licence : str
    """

    key: str
    name: str
    style: str
    filename: str
    source: str
    licence: str

    @property
    def path(self) -> Path:
        return resource_path("dems", self.filename)

    @property
    def thumbnail_path(self) -> Path:
        """Hillshade thumbnail PNG (made by ``scripts/make_thumbnails.py``)."""
        return resource_path("thumbnails", f"{self.key}.png")

    def load(self) -> HeightField:
        """Read the DEM, its nodata margins cut away
        (:meth:`~terrasynth_core.heightfield.HeightField.trim_nodata`).

        The ragged St. Helens quadrangle is cropped to its largest valid
        rectangle; the Himalayan basin clip keeps the whole basin, the
        nodata around it NaN (the engine keeps patches off it): its
        largest rectangle holds only half of its valid cells.
        """
        from .io import load_dem

        return load_dem(self.path).trim_nodata()


BUILTIN_EXAMPLES: tuple[BuiltinExample, ...] = (
    BuiltinExample(
        "white-mountains",
        "White Mountains, New Hampshire",
        "Glacially scoured old mountains: cirques, notches, rounded ridges",
        "N44W072.hgt",
        "NASA/USGS SRTM 3 arc-second tile N44W072",
        "public domain",
    ),
    BuiltinExample(
        "gabon-plateau",
        "North-western Gabon",
        "Low-relief tropical plateau with a dissected escarpment and dendritic valleys",
        "N00E010.hgt",
        "NASA/USGS SRTM 3 arc-second tile N00E010",
        "public domain",
    ),
    BuiltinExample(
        "big-tujunga",
        "Big Tujunga, San Gabriel Mountains, California",
        "Steep, tectonically active, fluvially dissected mountains with a deep canyon",
        "bigtujunga.tif",
        "SRTM 30 m, as distributed by TopoToolbox (DEMs repository)",
        "public domain",
    ),
    BuiltinExample(
        "himalaya",
        "Mandakini basin, Garhwal Himalaya, India",
        "High Himalaya: glaciated peaks, deep V-shaped valleys",
        "Mandakini.bil",
        "SRTM 90 m basin clip, as distributed by LSDTopoTools (ExampleTopoDatasets)",
        "public domain",
    ),
    BuiltinExample(
        "st-helens",
        "Mount St. Helens, Washington (1980, post-eruption)",
        "Stratovolcano: breached crater, radial gullies, debris apron",
        "SainteHelens.dem",
        "USGS 7.5-minute DEM, quadrangle MOUNT ST. HELENS (POST-ERUPTION)",
        "public domain",
    ),
)

#: The example a first-time user starts from.
DEFAULT_EXAMPLE = "white-mountains"
#: The sketch a first-time user starts from.
DEFAULT_SKETCH = "y_junction_512.png"


def resource_path(*parts: str) -> Path:
    """Path of a file in the installed resources folder."""
    return Path(str(resources.files("terrasynth_core.resources").joinpath(*parts)))


def builtin_example(key: str) -> BuiltinExample:
    """The built-in example called ``key``; the error lists the valid keys."""
    for ex in BUILTIN_EXAMPLES:
        if ex.key == key:
            return ex
    keys = ", ".join(ex.key for ex in BUILTIN_EXAMPLES)
    raise DEMFormatError(f"no built-in example called {key!r}; choose one of: {keys}")


def builtin_sketches() -> list[Path]:
    """Paths of the sketch maps shipped in ``resources/sketches`` (not the
    style-region and water maps of the multi-style presets beside them)."""
    return sorted(p for p in resource_path("sketches").glob("*.png")
                  if not p.stem.endswith(("_styles", "_water")))


def resolve_dem(spec: str | Path, *, size: tuple[int, int] | None = None, band: int | None = None) -> HeightField:
    """Load a DEM named by a path or by ``builtin:KEY``.

    Built-in examples come cropped to their valid area; files come as read
    (``size`` and ``band`` as in :func:`~terrasynth_core.io.load_dem`;
    built-ins have one band).
    """
    text = str(spec)
    if text.startswith(BUILTIN_PREFIX):
        if band not in (None, 1):
            raise DEMFormatError(f"{text}: band {band} does not exist; built-in examples have one band")
        return builtin_example(text[len(BUILTIN_PREFIX):]).load()
    from .io import load_dem

    if not Path(text).exists() and text in {ex.key for ex in BUILTIN_EXAMPLES}:
        # A built-in's bare name, not a file: say how to name it.
        raise DEMFormatError(f"{text}: no such file; the built-in example is {BUILTIN_PREFIX}{text}")
    return load_dem(text, size=size, band=band)
