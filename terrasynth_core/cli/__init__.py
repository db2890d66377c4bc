"""``terrasynth-cli``: the command line over the core."""

from .main import main

__all__ = ["main"]
