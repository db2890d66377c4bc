"""Fixtures shared by the core tests."""

from pathlib import Path

import pytest

from terrasynth_core.io import load_dem

#: The repository's built-in example DEMs.
DEMS_DIR = Path(__file__).parents[2] / "resources" / "dems"


@pytest.fixture(scope="session")
def dems_dir() -> Path:
    """Directory of the built-in DEMs (resources/dems)."""
    return DEMS_DIR


@pytest.fixture(scope="session")
def sketch_dir() -> Path:
    """The built-in sketch maps (resources/sketches)."""
    return Path(__file__).resolve().parents[2] / "resources" / "sketches"


# -- example DEMs shared by the engine's tests (read-only: copy before changing)


@pytest.fixture(scope="session")
def white_mountains():
    """A 400x400 corner of the White Mountains: quick but real."""
    field = load_dem(DEMS_DIR / "N44W072.hgt")
    return field.with_heights(field.heights[300:700, 300:700].copy())


@pytest.fixture(scope="session")
def lowland():
    """Gabon plateau, 300x300: gentle, a few hundred metres up."""
    field = load_dem(DEMS_DIR / "N00E010.hgt")
    return field.with_heights(field.heights[400:700, 400:700].copy())


@pytest.fixture(scope="session")
def highland():
    """Himalaya (Mandakini), its valid core: rugged, thousands of metres up."""
    return load_dem(DEMS_DIR / "Mandakini.bil").crop_valid()


@pytest.fixture(scope="session")
def helens():
    """Mount St. Helens (USGS ASCII DEM)."""
    return load_dem(DEMS_DIR / "SainteHelens.dem")
