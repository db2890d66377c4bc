"""The order feature patches are placed in (paper §4.1): breadth-first over
each sketch network, the networks with most patches first."""

from typing import TYPE_CHECKING

from .._lazy import lazy_exports

if TYPE_CHECKING:
    from .bfs import Component, breadth_first_components, feature_order

# Loaded on first use (terrasynth_core._lazy): importing the package costs nothing.
__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    ".bfs": ("Component", "breadth_first_components", "feature_order"),
})
