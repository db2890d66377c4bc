"""What every test shares: the disk cache out of the user's home."""

import pytest


@pytest.fixture(autouse=True)
def _private_analysis_cache(tmp_path_factory, monkeypatch):
    """Keep the example-analysis disk cache (analyses, fill indexes) out of
    the user's home, for the core's tests and the app's alike."""
    monkeypatch.setenv("TERRASYNTH_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "analysis-cache"))
