"""The order feature patches are placed in (paper §4.1): breadth-first over
each sketch network, the networks with most patches first."""

from .bfs import Component, breadth_first_components, feature_order

__all__ = ["Component", "breadth_first_components", "feature_order"]
