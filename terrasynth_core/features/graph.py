"""The feature graph: ridges or valleys as a forest of typed nodes and paths.

A :class:`FeatureGraph` is what PPA returns for a DEM and what sketch analysis
returns for a sketch map.  Nodes are *branch points* (degree >= 3) and
*endpoints* (degree 1); paths are polylines of ``(row, col)`` points running
from one node to another.  The graph is acyclic by construction (a forest).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal, overload

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


class NodeTable(Sequence):
    """:attr:`FeatureGraph.nodes` held as arrays (a stored analysis, mapped
    from its file): a :class:`FeatureNode` is made when asked for, so an
    example's thousands of nodes are not thousands of objects in every
    process that holds its analysis.

    Parameters
    ----------
    positions : ndarray of float, shape (n, 2)
        ``(row, col)`` of each node, cells.
    branch : ndarray of bool, shape (n,)
        True for a branch point, False for an endpoint.
    degrees : ndarray of int, shape (n,)
    """

    __slots__ = ("positions", "branch", "degrees")

    def __init__(self, positions: np.ndarray, branch: np.ndarray, degrees: np.ndarray):
        self.positions, self.branch, self.degrees = positions, branch, degrees

    def __len__(self) -> int:
        return len(self.degrees)

    @overload
    def __getitem__(self, i: int) -> FeatureNode: ...
    @overload
    def __getitem__(self, i: slice) -> tuple[FeatureNode, ...]: ...

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(self[j] for j in range(*i.indices(len(self))))
        i = range(len(self))[i]  # negative indices, and IndexError past the end
        r, c = self.positions[i]
        return FeatureNode(i, float(r), float(c), "branch" if self.branch[i] else "end", int(self.degrees[i]))


class PathTable(Sequence):
    """:attr:`FeatureGraph.paths` held as arrays: every path's points in one
    array, a :class:`FeaturePath` (its points a view) made when asked for.

    Parameters
    ----------
    ends : ndarray of int, shape (m, 2)
        Start and end node of each path.
    counts : ndarray of int, shape (m,)
        Points of each path.
    points : ndarray of float, shape (sum(counts), 2)
        The paths' points one after another, ``(row, col)`` cells.
    """

    __slots__ = ("ends", "offsets", "points")

    def __init__(self, ends: np.ndarray, counts: np.ndarray, points: np.ndarray):
        self.ends = ends
        self.offsets = np.concatenate([[0], np.cumsum(counts, dtype=np.int64)])
        # A plain view: slices of a memmap would each carry its mapping's attributes.
        self.points = np.asarray(points)

    def __len__(self) -> int:
        return len(self.ends)

    @overload
    def __getitem__(self, i: int) -> FeaturePath: ...
    @overload
    def __getitem__(self, i: slice) -> tuple[FeaturePath, ...]: ...

    def __getitem__(self, i):
        if isinstance(i, slice):
            return tuple(self[j] for j in range(*i.indices(len(self))))
        i = range(len(self))[i]
        a, b = self.ends[i]
        return FeaturePath(int(a), int(b), self.points[self.offsets[i]:self.offsets[i + 1]])


@dataclass(frozen=True, eq=False)
class FeatureGraph:
    """Ridges or valleys of one grid as an acyclic graph.

    Parameters
    ----------
    kind : {"ridge", "valley"}
    shape : (rows, cols)
        Shape of the grid the graph was extracted from.
    nodes : sequence of FeatureNode
        A tuple, or a :class:`NodeTable` for a stored analysis.
    paths : sequence of FeaturePath
        A tuple, or a :class:`PathTable`.
    """

    kind: FeatureKind
    shape: tuple[int, int]
    nodes: Sequence[FeatureNode]
    paths: Sequence[FeaturePath]

    # -- queries ----------------------------------------------------------
    def node_positions(self) -> np.ndarray:
        """``(row, col)`` of every node, ndarray of float, shape (n, 2), cells."""
        if isinstance(self.nodes, NodeTable):
            return np.asarray(self.nodes.positions, dtype=float)
        return np.array([[n.row, n.col] for n in self.nodes], dtype=float).reshape(-1, 2)

    def path_points(self) -> list[np.ndarray]:
        """Every path's points, a list of ndarray of float, shape (n_i, 2)."""
        if isinstance(self.paths, PathTable):
            pts, off = self.flat_paths()
            return [pts[a:b] for a, b in zip(off[:-1], off[1:])]
        return [p.points for p in self.paths]

    def flat_paths(self) -> tuple[np.ndarray, np.ndarray]:
        """Every path's points one after another, and where each path starts.

        Returns
        -------
        points : ndarray of float, shape (n, 2)
            ``(row, col)`` cells (a stored graph's own array, not a copy).
        offsets : ndarray of int64, shape (m + 1,)
            Path ``i`` is ``points[offsets[i]:offsets[i + 1]]``.
        """
        if isinstance(self.paths, PathTable):
            return np.asarray(self.paths.points, dtype=float), self.paths.offsets
        pts = [np.asarray(p.points, dtype=float) for p in self.paths]
        offsets = np.concatenate([[0], np.cumsum([len(p) for p in pts], dtype=np.int64)]).astype(np.int64)
        return (np.concatenate(pts) if pts else np.zeros((0, 2))), offsets

    def path_ends(self) -> np.ndarray:
        """Start and end node of every path, ndarray of int64, shape (m, 2)."""
        if isinstance(self.paths, PathTable):
            return np.asarray(self.paths.ends, dtype=np.int64)
        return np.array([[p.start, p.end] for p in self.paths], dtype=np.int64).reshape(-1, 2)

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
