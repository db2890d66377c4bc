"""Fixtures shared by the core tests."""

from pathlib import Path

import pytest

#: The repository's built-in example DEMs.
DEMS_DIR = Path(__file__).parents[2] / "resources" / "dems"


@pytest.fixture
def dems_dir() -> Path:
    """Directory of the built-in DEMs (resources/dems)."""
    return DEMS_DIR
