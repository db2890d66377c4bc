"""Fixtures shared by the core tests."""

from pathlib import Path

import pytest

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


@pytest.fixture(autouse=True)
def _private_analysis_cache(tmp_path_factory, monkeypatch):
    """Keep the example-analysis disk cache out of the user's home."""
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "analysis-cache"))
