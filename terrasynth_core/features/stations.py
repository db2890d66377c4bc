"""Where a sample's feature line runs inside its patch: the points at which
it crosses a circle of half the patch's inscribed radius.

A feature sample's control points are its centre and the crossings of the
inscribed circle (:mod:`.samples`), so a warp carries the example's feature
onto the stroke there and only there: halfway out, the example's line may
run a few cells off the stroke, and a valley a few cells wide then lies
beside the line the artist drew.  Matching these inner *stations* of the
example's line to the stroke's as well pins the feature to the stroke all
along the patch.
"""

from __future__ import annotations

import math

import numpy as np

from .graph import FeatureGraph
from .samples import NetworkSampler

#: Radius of the station circle, as a share of the patch's inscribed radius.
STATION_SHARE = 0.5

#: Most a station's direction from the centre may differ from its
#: crossing's, degrees: beyond it the line turns back or belongs to another
#: branch, and the pair would fold the warp.
MAX_TURN = 45.0


#: Farthest a route's exit may lie from the crossing it stands for, cells
#: (the same walk finds both; this only absorbs rounding).
MATCH_TOLERANCE = 1.0


class LineStations:
    """The stations of one network's samples.

    Parameters
    ----------
    graph : FeatureGraph
        The network the samples were taken on (their centres are its
        nodes and path points).
    radius : float
        The patch's inscribed radius, cells.
    """

    def __init__(self, graph: FeatureGraph, radius: float, *, keep=None):
        self._graph = graph
        self._walker = NetworkSampler(graph, radius, station_radius=STATION_SHARE * float(radius))
        self._keep = keep
        self._at: tuple[np.ndarray, np.ndarray] | None = None
        self._nodes: tuple[np.ndarray, np.ndarray] | None = None
        # Routes by centre: a sample's candidates share their sketch
        # centre, and an example centre comes back in many rankings.
        self._routes: dict[int, list] = {}

    def _where(self, key: int) -> tuple[int, int] | None:
        """``(-1, node)`` or ``(path, index)`` of the sample centre of key
        ``key`` (:func:`_keys`), or None (a centre on a node is walked from
        the node)."""
        if self._at is None:
            self._index()
        node = _find(*self._nodes, key, last=True)
        if node is not None:
            return -1, node
        at = _find(*self._at, key)
        return None if at is None else self._walker.locate(at)

    def _index(self) -> None:
        """Every node's and path point's key, sorted, with which node or
        where among the network's points it is (its path and index follow
        from that).  The points' index is as large as the network, and an
        example's is kept between sessions: made by ``keep(name, make,
        dtype)`` when given (the example cache's mapped arrays)."""
        n = len(self._walker.flat_points())
        dtype = np.int32 if n < 2**31 else np.int64
        keep = self._keep or (lambda name, make, dtype: make())
        order = keep("order", lambda: np.argsort(_keys(self._walker.flat_points()), kind="stable").astype(dtype), dtype)
        keys = keep("keys", lambda: _keys(self._walker.flat_points())[order], np.int64)
        node_keys = _keys(self._graph.node_positions())
        nodes = np.argsort(node_keys, kind="stable")
        self._nodes = node_keys[nodes], nodes
        # Last: an example's stations are shared between sessions, and
        # another thread takes a set ``_at`` for a finished index.
        self._at = keys, order

    def routes(self, centre: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
        """Every way out of the patch's disc from a sample centre: where it
        leaves the disc (a crossing, as :mod:`.samples` finds it) and where
        it crossed the station circle before.

        Parameters
        ----------
        centre : ndarray of float, shape (2,)
            A sample centre of this network, ``(row, col)`` cells.

        Returns
        -------
        list of (crossing, station), each ndarray of float, shape (2,)
            Empty when the centre is not on the network.
        """
        centre = np.asarray(centre, dtype=float)
        key = int(_keys(centre[None])[0])
        if key not in self._routes:
            where = self._where(key)
            if where is None:
                self._routes[key] = []
            elif where[0] < 0:
                self._routes[key] = self._walker.routes_from_node(centre, where[1])
            else:
                self._routes[key] = self._walker.routes_from_path(centre, *where)
        return self._routes[key]

    def inner(self, centre: np.ndarray, crossings: np.ndarray) -> np.ndarray:
        """The station on the way to each crossing.

        Parameters
        ----------
        centre : ndarray of float, shape (2,)
            A sample centre of this network, ``(row, col)`` cells.
        crossings : ndarray of float, shape (d, 2)
            The sample's crossings, in any order.

        Returns
        -------
        ndarray of float, shape (d, 2)
            Row ``j`` is where the route to ``crossings[j]`` crosses the
            station circle, NaN where there is no clean one: no route
            (the centre is not on the network), a station shared with
            another crossing's route (the two part beyond it), or one
            turned more than :data:`MAX_TURN` from its crossing's direction
            (the line doubles back: the pair would fold the warp).
        """
        crossings = np.asarray(crossings, dtype=float)
        found = np.full(crossings.shape, np.nan)
        routes = self.routes(centre)
        if not routes:
            return found
        # A handful of routes and crossings: plain floats beat array calls.
        cr, cc = float(centre[0]), float(centre[1])
        picked = []
        for r, c in crossings.tolist():
            gap, station = min(((math.hypot(r - e[0], c - e[1]), s) for e, s in routes), key=lambda t: t[0])
            picked.append(station if gap <= MATCH_TOLERANCE else None)
        for j, station in enumerate(picked):
            if station is None or sum(other is station for other in picked) > 1:
                continue  # no route, or a station two routes share
            turn = math.atan2(crossings[j, 0] - cr, crossings[j, 1] - cc) - math.atan2(station[0] - cr,
                                                                                     station[1] - cc)
            if abs(math.remainder(turn, math.tau)) <= math.radians(MAX_TURN):
                found[j] = station
        return found


def _find(keys: np.ndarray, values: np.ndarray, key: int, *, last: bool = False) -> int | None:
    """The value of ``key`` in the sorted ``keys`` (the last of equal keys
    with ``last``, else the first), or None."""
    at = int(np.searchsorted(keys, key, side="right" if last else "left")) - int(last)
    return int(values[at]) if 0 <= at < len(keys) and keys[at] == key else None


def _keys(points: np.ndarray) -> np.ndarray:
    """One integer per point, equal for points within a quarter cell's
    rounding: shape (n,) of int64."""
    q = np.rint(np.asarray(points, dtype=float) * 4).astype(np.int64)
    return q[:, 0] * (1 << 32) + q[:, 1]
