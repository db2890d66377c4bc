"""The feature graph: ridges or valleys as a forest of typed nodes and paths.

A :class:`FeatureGraph` is what PPA returns for a DEM and what sketch analysis
returns for a sketch map.  Nodes are *branch points* (degree >= 3) and
*endpoints* (degree 1); paths are polylines of ``(row, col)`` points running
from one node to another.  The graph is acyclic by construction (a forest).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

NodeType = Literal["branch", "end"]
FeatureKind = Literal["ridge", "valley"]


@dataclass(frozen=True, slots=True)
class FeatureNode:
    """A branch point or endpoint.

    Parameters
    ----------
    id : int
        Index of the node in :attr:`FeatureGraph.nodes`.
    row, col : float
        Position in grid cells.
    type : {"branch", "end"}
    degree : int
        Number of paths meeting here (1 for an end, >= 3 for a branch).
    """

    id: int
    row: float
    col: float
    type: NodeType
    degree: int


@dataclass(frozen=True, eq=False, slots=True)
class FeaturePath:
    """A polyline between two nodes.

    Parameters
    ----------
    start, end : int
        Node ids; ``points[0]`` is at node ``start`` and ``points[-1]`` at
        node ``end``.
    points : ndarray of float, shape (n, 2)
        ``(row, col)`` positions in grid cells, n >= 2.
    """

    start: int
    end: int
    points: np.ndarray

    @property
    def length(self) -> float:
        """Polyline length in cells."""
        return float(np.hypot(*np.diff(self.points, axis=0).T).sum())


@dataclass(frozen=True, eq=False)
class FeatureGraph:
    """Ridges or valleys of one grid as an acyclic graph.

    Parameters
    ----------
    kind : {"ridge", "valley"}
    shape : (rows, cols)
        Shape of the grid the graph was extracted from.
    nodes : tuple of FeatureNode
    paths : tuple of FeaturePath
    """

    kind: FeatureKind
    shape: tuple[int, int]
    nodes: tuple[FeatureNode, ...]
    paths: tuple[FeaturePath, ...]

    # -- queries ----------------------------------------------------------
    def degree(self, node_id: int) -> int:
        return self.nodes[node_id].degree

    def neighbours(self, node_id: int) -> list[tuple[int, int]]:
        """``(path index, other node id)`` for each path at ``node_id``."""
        out = []
        for i, p in enumerate(self.paths):
            if p.start == node_id:
                out.append((i, p.end))
            elif p.end == node_id:
                out.append((i, p.start))
        return out

    def is_acyclic(self) -> bool:
        """True when no path closes a loop (union-find over the paths)."""
        parent = list(range(len(self.nodes)))

        def find(a: int) -> int:
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        for p in self.paths:
            a, b = find(p.start), find(p.end)
            if a == b:
                return False
            parent[a] = b
        return True

    def count(self, node_type: NodeType) -> int:
        return sum(1 for n in self.nodes if n.type == node_type)

    def total_length(self) -> float:
        """Summed length of all paths, in cells."""
        return sum(p.length for p in self.paths)

    def rasterize(self, width: int = 1) -> np.ndarray:
        """Boolean mask, shape :attr:`shape`, of the cells the paths pass.

        Parameters
        ----------
        width : int
            Line width in cells (1 = the bare polylines).
        """
        from skimage.draw import line

        rows, cols = self.shape
        mask = np.zeros(self.shape, dtype=bool)
        for p in self.paths:
            pts = np.rint(p.points).astype(np.int64)
            for (r0, c0), (r1, c1) in zip(pts[:-1], pts[1:]):
                rr, cc = line(r0, c0, r1, c1)
                ok = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
                mask[rr[ok], cc[ok]] = True
        if width > 1:
            from scipy import ndimage

            mask = ndimage.binary_dilation(mask, iterations=width // 2)
        return mask

    # -- serialisation ----------------------------------------------------
    def to_dict(self) -> dict:
        """JSON-ready ``{"nodes": [...], "paths": [...]}`` (the CLI's format)."""
        return {
            "nodes": [
                {"id": n.id, "row": round(n.row, 2), "col": round(n.col, 2), "type": n.type, "degree": n.degree}
                for n in self.nodes
            ],
            "paths": [
                {"from": p.start, "to": p.end, "points": np.round(p.points, 2).tolist()}
                for p in self.paths
            ],
        }

    @classmethod
    def from_dict(cls, data: dict, kind: FeatureKind, shape: tuple[int, int]) -> "FeatureGraph":
        nodes = tuple(
            FeatureNode(int(n["id"]), float(n["row"]), float(n["col"]), n["type"], int(n.get("degree", 0)))
            for n in data["nodes"]
        )
        paths = tuple(
            FeaturePath(int(p["from"]), int(p["to"]), np.asarray(p["points"], dtype=float))
            for p in data["paths"]
        )
        return cls(kind, tuple(shape), nodes, paths)


@dataclass(frozen=True, eq=False)
class FeatureMaps:
    """Ridges and valleys of one grid."""

    ridges: FeatureGraph
    valleys: FeatureGraph

    def to_dict(self) -> dict:
        return {"ridges": self.ridges.to_dict(), "valleys": self.valleys.to_dict()}
