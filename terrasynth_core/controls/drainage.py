"""Valleys drain, ridges divide: the sketch's networks shaped into a drainage
network on the finished heights.

A painted valley network is meant as a drainage network: its floor descends
towards an outlet, with no closed depression along it, and tributaries meet
the main valley at its floor.  Synthesis does not promise that (a valley is
pieced from example patches, and a fill patch or a seam can leave a dam
across it), so this finish step makes it so:

1. **Floor profile.**  Each valley path is sampled every 0.7 cell; the floor
   at a point is the lowest height on the stroke's cross-section within a
   tenth of a patch (the synthesized thalweg is rarely exactly under the
   stroke).  A cross-section rather than a disc: a disc's minimum hides a
   dam narrower than the disc (a seam, say).
2. **Outlet.**  Per connected network: the end touching the map border or
   painted water (the lowest of them), else the lowest end.
3. **Monotone fit.**  The network is rooted at the outlet and cut into
   chains, longest route first (the trunk from the outlet to its farthest
   source, then every tributary from its junction).  On each chain the floor
   gets the L2 isotonic regression (pool adjacent violators) of
   ``floor - eps * s`` plus ``eps * s`` (``s``: distance from the chain's
   start): the non-decreasing-upstream profile closest to the floor in the
   least-squares sense, with a minimum gradient ``eps`` (2e-5 of the height
   span per cell) so water runs instead of pooling.  A dam is partly cut
   and the lake behind it partly filled, whichever moves less; an upstream
   cumulative maximum would fill every lake to its dam (long flat floors),
   a cumulative minimum would cut every dam down to the lake (gorges).  A
   tributary starts at the fitted height of the trunk at the junction and
   stays above it; its first cells are left to the trunk's correction (its
   cross-section there reaches the trunk's floor).  A source is never
   lowered: that would dig a pit at the valley's head.
4. **Smooth correction.**  The change ``fit - floor`` is pinned on the
   floor cells (the lowest cell of each sample's cross-section: the
   thalweg, on or next to the centreline) and spread by the pins' solver
   (:func:`.pins.smooth_correction_cells`: least squared Laplacian, zero with zero
   slope at a valley half-width, a third of a patch), solved on a grid three
   times coarser (the field is smooth on that scale) and interpolated: a
   broad, smooth lowering or raising of the valley with its own detail
   kept, not a trench.  Up to two more passes resample and refit, for the
   interpolation's residual and floors that moved to another cell; the
   last on the full grid (only where a residual is left), since
   centimetres are enough for a pit in a floor fitted nearly flat.

5. **Breach.**  An outlet that is not on the map border or painted water
   may lie in a closed depression: a valley painted inside a ring of
   ridges, or ending in a basin of the synthesized terrain.  Its water
   would pool there (a lake as wide as the basin), so the network would
   not drain.  Within three patches of the outlet the heights are filled
   to their spill level; if the outlet's is above its fitted floor, the
   path of least total height above that floor to a cell that spills
   lower is cut down so that it descends all the way (least-cost
   breaching, Lindsay 2016): a water gap through the rim at its lowest
   saddle.  The path is found on the first pass and cut, once the
   valleys' first correction is in, on the full grid (a coarse solve
   blunts a gorge's floor) as wide as keeps its walls no steeper than the
   terrain's steep slopes (at most three valley half-widths); what is
   left goes with the valleys' later passes.  Its first cells, at the
   outlet, are pinned too, so the gorge does not spread into the valley's
   outlet (whose floor the next fit would follow down, and the gorge after
   it).  A breach that would run within that width of a locked cell is
   not made (the outlet pools): it could not be cut there, and a cut
   beside the lock would overshoot against it.  Breaching comes after
   the ridges' step, so a gap may cross a painted ridge: the ring of a
   ring-and-cross sketch has to open somewhere for its valleys to drain.

Ridges divide: along each painted ridge the crest (the highest height on
the cross-section within a twentieth of a patch) is compared with the
terrain beside it (up to a sixth of a patch on either side).  Where the
crest is lower than the terrain beside it *and* lies in a notch of the
crest profile (below the crest on both sides along the ridge), a stream
can cross: the crest is raised there by a smooth hump over the notch, to
the lower of the two flanking crest heights but at most 5 % of the height
span, with the
same smooth correction over a sixth of a patch (one pass).  Crests that
descend along the ridge are left alone, so it stays local and modest.  It
cannot make a crest out of a stroke painted across a slope: that is the
synthesis's job (the ridge's feature patches).

Cells locked by a local re-synthesis never change; cells farther than the
half-widths from every corrected stroke keep their bytes.

The step reads the heights only along the strokes and keeps each
correction as its values on the cells it changes (:class:`Correction`), so
a world-size map drains without being held in memory: a tiled run
(:mod:`terrasynth_core.tiled.drainage`) reads its finished tiles and adds
the corrections band by band as it writes the GeoTIFF, and gives the same
bytes as :func:`apply_drainage` on the whole map.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np
from scipy import ndimage, sparse
from scipy.optimize import isotonic_regression
from scipy.sparse.csgraph import connected_components
from skimage.graph import MCP_Geometric
from skimage.morphology import reconstruction

from ..features.graph import FeatureGraph
from ..measures import surface_gradient
from .pins import positions, smooth_correction_cells

#: Radius of the disc a floor (or crest) is sampled in, in patches.
FLOOR_RADIUS = 0.1
CREST_RADIUS = 0.05
#: Distance over which a correction fades to zero, in patches.
VALLEY_HALF_WIDTH = 1.0 / 3.0
RIDGE_HALF_WIDTH = 1.0 / 6.0
#: Least floor gradient, as a share of the terrain's height span per cell.
MIN_SLOPE = 2e-5
#: Most a crest is raised, as a share of the terrain's height span.
RIDGE_MAX_RAISE = 0.05
#: Spacing of the samples along a stroke, cells.
STEP = 0.7
#: Fit-and-correct passes.
PASSES = 3
#: The last pass's correction width, as a share of the valley half-width.
FINAL_WIDTH = 1.0 / 3.0
#: How far from an outlet in a closed depression its breach is looked for,
#: in patches (and at least :data:`BREACH_MIN_REACH` cells).
BREACH_REACH = 3.0
BREACH_MIN_REACH = 64
#: Widest a breach's gorge is, as a multiple of the valley half-width.
BREACH_MAX_WIDTH = 3.0


class Surface(Protocol):
    """Heights the step reads and corrects: an array's, or a tiled run's.

    ``shape``; ``surface[rr, cc]`` the float32 heights at integer cell
    arrays (any shape); ``add(correction)`` adds a correction to what later
    reads return.
    """

    shape: tuple[int, int]

    def __getitem__(self, cells: tuple[np.ndarray, np.ndarray]) -> np.ndarray: ...

    def add(self, correction: "Correction") -> None: ...


class Mask(Protocol):
    """A map of cells (locked, water), read where needed: ``mask.at(rr,
    cc)`` at integer cell arrays, ``mask.window((r0, r1, c0, c1))`` over a
    box; both bool."""

    def at(self, rr: np.ndarray, cc: np.ndarray) -> np.ndarray: ...

    def window(self, box: tuple[int, int, int, int]) -> np.ndarray: ...


class ArrayMask:
    """:class:`Mask` over a whole-map array."""

    def __init__(self, mask: np.ndarray):
        self.mask = np.asarray(mask, bool)

    def at(self, rr: np.ndarray, cc: np.ndarray) -> np.ndarray:
        return self.mask[rr, cc]

    def window(self, box: tuple[int, int, int, int]) -> np.ndarray:
        r0, r1, c0, c1 = box
        return self.mask[r0:r1, c0:c1]


class ArraySurface:
    """:class:`Surface` over a whole-map float32 array, corrected in place."""

    def __init__(self, heights: np.ndarray):
        self.heights = heights
        self.shape = heights.shape

    def __getitem__(self, cells):
        return self.heights[cells]

    def add(self, correction: "Correction") -> None:
        rows, cols = self.shape
        correction.apply((0, rows, 0, cols), self.heights)


def apply_drainage(heights: np.ndarray, valleys: FeatureGraph | None, ridges: FeatureGraph | None, *,
                   patch_size: int, water: np.ndarray | None = None,
                   locked: np.ndarray | None = None) -> np.ndarray:
    """Make painted valleys drain to an outlet and painted ridges divide.

    Parameters
    ----------
    heights : ndarray of float32, shape (rows, cols)
        Finished heights, metres; not modified.
    valleys, ridges : FeatureGraph or None
        The sketch's networks in output cells.
    patch_size : int
        Sets the sampling disc and correction widths.
    water : ndarray of bool, shape (rows, cols), optional
        Painted water: a valley end touching it is an outlet.
    locked : ndarray of bool, shape (rows, cols), optional
        Cells that must not change (outside a local re-synthesis).

    Returns
    -------
    ndarray of float32, shape (rows, cols)
        Corrected heights; cells beyond the correction widths are
        bit-identical to ``heights``.
    """
    out = np.array(heights, dtype=np.float32, copy=True)
    span = float(np.ptp(out)) if out.size else 0.0
    drain(ArraySurface(out), valleys, ridges, patch_size=patch_size, span=span,
          water=None if water is None or not np.any(water) else ArrayMask(water),
          locked=None if locked is None else ArrayMask(locked))
    return out


def drain(surface: Surface, valleys: FeatureGraph | None, ridges: FeatureGraph | None, *, patch_size: int,
          span: float, water: Mask | None = None, locked: Mask | None = None) -> None:
    """:func:`apply_drainage` on any :class:`Surface`: the corrections are
    added to ``surface`` one after the other (the ridges', then up to
    :data:`PASSES` of the valleys', the first followed by one per breach).

    Parameters
    ----------
    surface : Surface
    valleys, ridges : FeatureGraph or None
        In the surface's cells.
    patch_size : int
    span : float
        The surface's height span (max - min), metres: sets the least
        floor gradient and the most a crest is raised.
    water, locked : Mask, optional
        Painted water (a valley end touching it is an outlet) and cells that
        must not change.
    """
    if not np.isfinite(span) or span <= 0:
        return
    eps = MIN_SLOPE * span
    shape = surface.shape
    if ridges is not None and ridges.paths:
        r_crest = max(1, int(round(CREST_RADIUS * patch_size)))
        width = max(3.0, RIDGE_HALF_WIDTH * patch_size)
        pins = _ridge_pins(surface, ridges, r_crest, width, eps, RIDGE_MAX_RAISE * span)
        correction = _correction(shape, pins, width, locked, tol=1e-4 * span, pin_zeros=False)
        if correction is not None:
            surface.add(correction)
    if valleys is not None and valleys.paths:
        r_floor = max(1, int(round(FLOOR_RADIUS * patch_size)))
        width = max(3.0, VALLEY_HALF_WIDTH * patch_size)
        breaches: dict[int, Breach | None] = {}
        reach = max(BREACH_MIN_REACH, int(round(BREACH_REACH * patch_size)))
        for n in range(PASSES):
            pins, cuts = _valley_pins(surface, valleys, r_floor, eps, water, locked, breaches, reach,
                                      int(np.ceil(BREACH_MAX_WIDTH * width)))
            if n > 0:
                # What the first cut left of a breach goes with the valleys
                # (but for the outlet's own cell, which the valley's fit pins).
                for breach, level in cuts:
                    cells, change = _breach_pins(surface, breach.path, level, eps)
                    pins.append((cells[1:], change[1:]))
            # The last pass on the full grid: the coarse solve leaves
            # centimetres, enough for a pit in a floor fitted nearly flat.
            # Centimetres fade out over a third of the width unseen, and the
            # full-grid solve gets a third of the unknowns (4x faster).
            last = n == PASSES - 1
            correction = _correction(shape, pins, max(3.0, width * FINAL_WIDTH) if last else width, locked,
                                     tol=1e-5 * span, coarse=not last)
            if correction is not None:
                surface.add(correction)
            changed = correction is not None
            if n == 0:
                # A breach is first cut on the heights the valleys'
                # correction left (it reaches the outlet's first cells), as
                # a gorge as wide as its depth asks, so its walls are no
                # steeper than the terrain's steep slopes, on the full grid
                # (a coarse solve blunts the gorge's floor).
                for breach, level in cuts:
                    pin = _breach_pins(surface, breach.path, level, eps)
                    gorge = 2.0 * float(-pin[1].min(initial=0.0)) / breach.steep
                    cut = _correction(shape, [pin], float(np.clip(gorge, width, BREACH_MAX_WIDTH * width)), locked,
                                      tol=1e-5 * span, coarse=False)
                    if cut is not None:
                        surface.add(cut)
                        changed = True
            if not changed:
                break


# -- sampling -------------------------------------------------------------------

def _disc(radius: int) -> np.ndarray:
    y, x = np.mgrid[-radius:radius + 1, -radius:radius + 1]
    return x * x + y * y <= radius * radius


def _resample(points: np.ndarray) -> np.ndarray:
    """``points`` (n, 2) resampled every :data:`STEP` cells, ends kept."""
    seg = np.hypot(*np.diff(points, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(int(np.ceil(s[-1] / STEP)), 1) + 1
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack([np.interp(t, s, points[:, 0]), np.interp(t, s, points[:, 1])])


def _cells(points: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    r = np.clip(np.rint(points[:, 0]).astype(np.int64), 0, shape[0] - 1)
    c = np.clip(np.rint(points[:, 1]).astype(np.int64), 0, shape[1] - 1)
    return r, c


def _normals(points: np.ndarray) -> np.ndarray:
    """Unit normals of a polyline, (n, 2) as (row, col)."""
    tangent = np.gradient(points, axis=0) if len(points) > 1 else np.array([[0.0, 1.0]])
    tangent = tangent / np.maximum(np.hypot(tangent[:, 0], tangent[:, 1]), 1e-9)[:, None]
    return np.column_stack([-tangent[:, 1], tangent[:, 0]])


def _lowest(h: Surface, points: np.ndarray, radius: int, sign: float = 1.0):
    """The lowest height (``sign=-1``: highest) on the cross-section of the
    stroke within ``radius`` of each point, and its cell; ties go to the
    cell nearest the stroke.  A cross-section, not a disc, so a dam
    narrower than the disc still shows."""
    t = np.arange(-radius, radius + 0.25, 0.5)
    q = points[:, None, :] + t[None, :, None] * _normals(points)[:, None, :]
    rr, cc = _cells(q.reshape(-1, 2), h.shape)
    rr, cc = rr.reshape(q.shape[:2]), cc.reshape(q.shape[:2])
    v = sign * h[rr, cc].astype(np.float64)
    k = np.argmin(v + 1e-9 * (t * t)[None, :], axis=1)
    i = np.arange(len(points))
    return sign * v[i, k], np.column_stack([rr[i, k], cc[i, k]]).astype(float)


def _arc_length(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])


# -- valleys --------------------------------------------------------------------

def _valley_pins(h: Surface, graph: FeatureGraph, radius: int, eps: float, water: Mask | None,
                 locked: Mask | None, breaches: dict, reach: int, guard: int) -> tuple[list, list]:
    """Per chain of every network: its points and the change that makes its
    floor descend to the outlet.

    Parameters
    ----------
    h : Surface
    graph : FeatureGraph
        The valleys.
    radius : int
        Half-width of a floor's cross-section, cells.
    eps : float
        Least floor gradient, metres per cell.
    water, locked : Mask or None
        Painted water (outlets) and cells that must not change.
    breaches : dict
        Breaches found so far by outlet node (:func:`_breach`; None: none
        needed or none possible); filled in place on the first call.
    reach, guard : int
        The breach search's half-window and how close to a locked cell a
        breach may run, cells.

    Returns
    -------
    pins : list of (cells, change)
        ``cells`` (n, 2) row, col; ``change`` (n,) metres.
    cuts : list of (Breach, float)
        For each network whose outlet lies in a closed depression, its
        breach (:func:`_breach`, found on the first pass and kept in
        ``breaches`` by outlet node) and the outlet's fitted floor, metres
        (:func:`_breach_pins` makes the cut).
    """
    rows, cols = h.shape
    disc = _disc(radius)

    def floor(points):
        return _lowest(h, points, radius)

    def touches(node) -> bool:
        r, c = node.row, node.col
        if min(r, c, rows - 1 - r, cols - 1 - c) <= radius:
            return True
        if water is not None:
            # Water within the disc about the node's cell.
            rr, cc = _cells(np.array([[r, c]]), h.shape)
            r0, c0 = int(rr[0]) - radius, int(cc[0]) - radius
            a0, a1 = max(r0, 0), min(r0 + 2 * radius + 1, rows)
            b0, b1 = max(c0, 0), min(c0 + 2 * radius + 1, cols)
            return bool((water.window((a0, a1, b0, b1)) & disc[a0 - r0:a1 - r0, b0 - c0:b1 - c0]).any())
        return False

    adj: dict[int, list[tuple[int, int]]] = {}
    for i, p in enumerate(graph.paths):
        adj.setdefault(p.start, []).append((i, p.end))
        adj.setdefault(p.end, []).append((i, p.start))
    dense = [_resample(np.asarray(p.points, float)) for p in graph.paths]
    out, cuts = [], []
    seen: set[int] = set()
    for first in adj:
        if first in seen:
            continue
        # One network: its nodes, breadth first.
        comp, queue = [], [first]
        seen.add(first)
        while queue:
            n = queue.pop()
            comp.append(n)
            for _, m in adj[n]:
                if m not in seen:
                    seen.add(m)
                    queue.append(m)
        ends = [n for n in comp if len(adj[n]) == 1] or comp
        touching = [n for n in ends if touches(graph.nodes[n])]
        outlets = touching or ends
        node_floor = {n: float(floor(np.array([[graph.nodes[n].row, graph.nodes[n].col]]))[0][0]) for n in outlets}
        outlet = min(outlets, key=lambda n: (node_floor[n], n))
        chains, level, cell = _fit_network(graph, adj, dense, outlet, floor, eps, radius)
        out.extend(chains)
        if not touching and cell is not None:
            if outlet not in breaches:
                breaches[outlet] = _breach(h, cell, level, reach, eps, water, locked, guard)
            if breaches[outlet] is not None:
                cuts.append((breaches[outlet], level))
    return out, cuts


def _fit_network(graph, adj, dense, outlet, floor, eps, radius):
    """Root the network at ``outlet``, cut it into chains (longest route
    first) and fit each chain's floor.

    Returns
    -------
    pins : list of (cells, change)
        Per chain, as :func:`_valley_pins`.
    level : float
        The fitted floor at the outlet, metres (NaN without a chain).
    cell : ndarray of float, shape (2,), or None
        The outlet's floor cell (row, col).
    """
    children: dict[int, list[tuple[int, int]]] = {}
    order, parent = [outlet], {outlet: None}
    for n in order:
        children[n] = []
        for i, m in adj[n]:
            if m not in parent:
                parent[m] = n
                children[n].append((i, m))
                order.append(m)

    def oriented(i, frm):
        pts = dense[i]
        return pts if graph.paths[i].start == frm else pts[::-1]

    reach = {}
    for n in reversed(order):
        reach[n] = max((len(dense[i]) + reach[m] for i, m in children[n]), default=0)
    pins = []
    level, cell = float("nan"), None
    # A chain starts at a node (the outlet, or a junction on a chain already
    # fitted, whose fitted height it starts from), leaves it by one path
    # (None: the longest) and then follows the longest route to a source.
    stack: list[tuple[int, tuple[int, int] | None, float | None]] = [(outlet, None, None)]
    while stack:
        node, first, start = stack.pop()
        parts = [np.array([[graph.nodes[node].row, graph.nodes[node].col]], float)]
        branches = []
        cur = node
        while children[cur]:
            i, m = first if first is not None else max(children[cur],
                                                        key=lambda im: len(dense[im[0]]) + reach[im[1]])
            if first is None:
                here = sum(len(p) for p in parts) - 1
                branches.extend((cur, here, jk) for jk in children[cur] if jk != (i, m))
            first = None
            parts.append(oriented(i, cur)[1:])
            cur = m
        pts = np.concatenate(parts)
        if len(pts) < 2:
            continue
        f, at = floor(pts)
        s = _arc_length(pts)
        g = _descending_fit(f, s, eps, start)
        if start is None:
            level, cell = float(g[0]), at[0]
        # Near its junction a tributary's cross-section reaches the trunk,
        # whose floor the trunk's own fit sets: pinned from both, a trunk
        # cell below the junction would be raised to the tributary's level.
        keep = s > radius + 1 if start is not None else np.ones(len(s), bool)
        pins.append((at[keep], (g - f)[keep]))
        for b_node, index, jk in branches:
            stack.append((b_node, jk, float(g[index])))
    return pins, level, cell


def _descending_fit(floor: np.ndarray, s: np.ndarray, eps: float, start: float | None) -> np.ndarray:
    """The profile nearest ``floor`` (least squares) that rises by at least
    ``eps`` per cell along ``s``, is not below ``floor`` at its last point
    (the source: lowered, it would be a pit at the valley's head) and,
    given ``start``, begins there."""
    tilted = floor - eps * s
    fit = isotonic_regression(tilted, increasing=True).x
    if fit[-1] < tilted[-1]:
        # Under a lower bound on the last point: that point at its bound and
        # the rest the unbounded fit clipped to it (isotonic regression under
        # a constant bound is the clipped unbounded fit).
        fit = np.minimum(isotonic_regression(tilted[:-1], increasing=True).x, tilted[-1]) \
            if len(tilted) > 1 else fit
        fit = np.append(fit, tilted[-1]) if len(tilted) > 1 else tilted.copy()
    if start is not None:
        fit = np.maximum(fit, start)
        fit[0] = start
    return fit + eps * s


# -- breaches -------------------------------------------------------------------

class Breach(NamedTuple):
    """Where an outlet's water gets out (:func:`_breach`).

    ``path`` (n, 2): cells (row, col) from the outlet outward; ``steep``:
    the terrain's steep slope about it (90th percentile of the gradient
    magnitude in the window searched), metres per cell."""

    path: np.ndarray
    steep: float


def _breach(h: Surface, cell: np.ndarray, level: float, reach: int, eps: float,
            water: Mask | None, locked: Mask | None = None, guard: int = 0) -> Breach | None:
    """Where the water of an outlet in a closed depression gets out: the
    path from the outlet's floor cell to the cell that drains below it at
    the least cut (least-cost breaching, Lindsay 2016).  None when the
    outlet drains already, when nothing within reach spills lower, or
    when the path runs within ``guard`` cells of a locked cell.

    Within ``reach`` cells of the outlet, the heights are filled to their
    spill level (priority flood by morphological reconstruction, water
    leaving at the window's border and at painted water).  If the outlet's
    spill level is above its fitted floor ``level``, the outlet is in a
    closed depression (a valley painted inside a ring of ridges, or ending
    in a basin of the synthesized terrain): the path is the one of least
    total height above ``level`` to a cell whose spill level is below it,
    so it crosses the rim where there is least to cut (near its lowest
    saddle).  :func:`_breach_pins` cuts it down into a gorge that descends
    all the way: a water gap.

    Parameters
    ----------
    h : Surface
    cell : ndarray of float, shape (2,)
        The outlet's floor cell (row, col).
    level : float
        Its fitted floor height, metres.
    reach : int
        Half-side of the window searched, cells.
    eps : float
        The least floor gradient, metres per cell (also the price of a step
        along the path, so of equal cuts the shorter path wins).
    water, locked : Mask or None
        Painted water (exits) and cells that must not change.
    guard : int
        How close to a locked cell the path may run, cells (the gorge's
        widest half-width).

    Returns
    -------
    Breach or None

    References
    ----------
    Lindsay, J. B. (2016). Efficient hybrid breaching-filling sink removal
    methods for flow path enforcement in digital elevation models.
    Hydrological Processes 30(6).
    """
    rows, cols = h.shape
    r, c = (int(v) for v in np.rint(cell))
    r0, r1 = max(r - reach, 0), min(r + reach + 1, rows)
    c0, c1 = max(c - reach, 0), min(c + reach + 1, cols)
    rr, cc = np.meshgrid(np.arange(r0, r1), np.arange(c0, c1), indexing="ij")
    heights = h[rr, cc].astype(np.float64)
    exits = np.zeros(heights.shape, bool)
    exits[[0, -1], :] = True
    exits[:, [0, -1]] = True
    if water is not None:
        exits |= water.window((r0, r1, c0, c1))
    spill = spill_levels(heights, exits)
    here = (r - r0, c - c0)
    if spill[here] <= level + eps:
        return None
    # Nothing within reach spills below the outlet (a valley cut deep into
    # high country): a breach would be a canyon across the map, so the
    # outlet is left to pool.
    ends = spill < level - eps
    if not ends.any():
        return None
    steps = least_cut_path(heights, here, level, ends, eps)
    if steps is None:
        return None
    if locked is not None:
        # A gorge cannot be cut through cells that must not change, and one
        # cut beside them would overshoot against them: the outlet pools.
        held = locked.window((r0, r1, c0, c1))
        if held.any():
            on_path = np.ones(heights.shape, bool)
            on_path[steps[:, 0], steps[:, 1]] = False
            if (held & (ndimage.distance_transform_edt(on_path) <= guard)).any():
                return None
    path = steps.astype(float) + np.array([r0, c0], float)
    gr, gc, _ = surface_gradient(heights, cell_size=1.0)
    return Breach(path, max(float(np.percentile(np.hypot(gr, gc), 90)), 1e-6))


def spill_levels(heights: np.ndarray, exits: np.ndarray) -> np.ndarray:
    """``heights`` filled to their spill levels, water leaving at
    ``exits`` (bool, same shape): priority flood by morphological
    reconstruction (Barnes et al. 2014's fill; scikit-image).

    Returns
    -------
    ndarray of float64, the shape of ``heights``
        At or above ``heights``; above it in every closed depression.
    """
    heights = np.asarray(heights, dtype=np.float64)
    return reconstruction(np.where(exits, heights, heights.max()), heights, method="erosion")


#: 8-neighbour connectivity (the minimum-cost path's moves).
_EIGHT = np.ones((3, 3), bool)


def least_cut_path(heights: np.ndarray, start: tuple[int, int], level: float, ends: np.ndarray, step: float,
                   passable: np.ndarray | None = None, free_start: bool = False) -> np.ndarray | None:
    """The path from ``start`` to one of ``ends`` that needs the least
    total cut down to ``level`` (least-cost breaching, Lindsay 2016): a
    cell costs its height above ``level``, plus ``step`` so that of equal
    cuts the shorter path wins (scikit-image's minimum-cost path, 8
    neighbours).

    Parameters
    ----------
    heights : ndarray of float64, shape (h, w)
        Metres.
    start : (row, col)
    level : float
        Metres.
    ends : ndarray of bool, shape (h, w)
        Where the path may end.
    step : float
        Metres a cell.
    passable : ndarray of bool, shape (h, w), optional
        Cells the path may cross (None: all).
    free_start : bool
        The start costs nothing (a depression's lowest cell, which is not
        cut); else it costs as any cell.

    Returns
    -------
    ndarray of int, shape (n, 2), or None
        Cells (row, col) from ``start``; None when no end is reachable.
    """
    costs = np.maximum(heights - level, 0.0) + step
    if passable is not None:
        costs = np.where(passable, costs, np.inf)  # (impassable to the search)
        # An end the start cannot reach costs the search as much as one it
        # can (scikit-image checks its targets as it goes: 1.2 s for 22,000
        # against 24 ms for the search alone), and a basin walled in by
        # painted ridges has no reachable end at all.
        regions, _ = ndimage.label(passable, structure=_EIGHT)
        ends = ends & (regions == regions[start])
        if not ends.any():
            return None
    if free_start:
        costs[start] = 0.0
    search = MCP_Geometric(costs, fully_connected=True)
    # Told its targets, the search stops at the first it settles: the
    # cheapest (the whole window's costs took as long again on average).
    # Only each end region's rim is told: a path enters a region at its rim,
    # and every cell costs at least ``step``, so a rim cell is settled before
    # any cell inside (the same path, for a fraction of the targets).
    inside = ndimage.binary_erosion(ends if passable is None else ends | ~passable, structure=_EIGHT,
                                    border_value=1)
    targets = np.argwhere(ends & ~inside)
    total, _ = search.find_costs([start], [tuple(t) for t in targets], find_all_ends=False)
    reach = total[targets[:, 0], targets[:, 1]]
    best = int(np.argmin(reach))
    if not np.isfinite(reach[best]):
        return None
    return np.asarray(search.traceback(tuple(targets[best])))


def _breach_pins(h: Surface, path: np.ndarray, level: float, eps: float) -> tuple[np.ndarray, np.ndarray]:
    """The cut that makes a breach path (:func:`_breach`) descend from the
    outlet's fitted floor ``level`` by at least ``eps`` per cell: on each
    cell the highest height that is below every cell before it (less the
    gradient) and not above the terrain, so the path is only ever lowered.

    Read after the valleys' correction, the outlet's first cells are
    already near ``level`` and are pinned too, so the gorge's correction
    does not spread into the valley's outlet (whose floor the next pass's
    fit would follow down, and the gorge after it).

    Returns
    -------
    cells : ndarray of float, shape (n, 2)
        The path (row, col).
    change : ndarray of float64, shape (n,)
        Metres, never positive.
    """
    heights = h[_cells(path, h.shape)].astype(np.float64)
    s = _arc_length(path)
    ceiling = np.minimum(heights, level)
    ceiling[0] = level
    target = np.minimum.accumulate(ceiling + eps * s) - eps * s
    return path, np.minimum(target - heights, 0.0)


# -- ridges ---------------------------------------------------------------------

def _ridge_pins(h: Surface, graph: FeatureGraph, radius: int, width: float,
                eps: float, cap: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per ridge path: its crest cells and the raise (at most ``cap``) that
    closes its notches."""
    pins = []
    offsets = np.arange(radius + 1, int(np.ceil(width)) + 1, dtype=float)
    for p in graph.paths:
        pts = _resample(np.asarray(p.points, float))
        if len(pts) < 3 or offsets.size == 0:
            continue
        crest, at = _lowest(h, pts, radius, sign=-1.0)
        normal = _normals(pts)
        side = np.full(len(pts), -np.inf)
        for sign in (1.0, -1.0):
            for d in offsets:
                q = pts + sign * d * normal
                inside = (q[:, 0] > -0.5) & (q[:, 0] < h.shape[0] - 0.5) & (q[:, 1] > -0.5) & (q[:, 1] < h.shape[1] - 0.5)
                v = np.where(inside, h[_cells(q, h.shape)].astype(np.float64), -np.inf)
                side = np.maximum(side, v)
        # A notch: below the crest on both sides along the ridge.
        dam = np.minimum(np.maximum.accumulate(crest), np.maximum.accumulate(crest[::-1])[::-1])
        want = np.where(side > crest, dam, crest)
        # A smooth hump over the whole notch (no spike between two crest
        # cells), never more than ``cap``.
        raise_by = np.maximum(want - crest, 0.0)
        raise_by = ndimage.maximum_filter1d(raise_by, size=int(width) | 1, mode="nearest")
        raise_by = np.clip(ndimage.gaussian_filter1d(raise_by, width / 3, mode="nearest"), 0.0, cap)
        if raise_by.any():
            pins.append((at, raise_by))
    return pins


# -- the correction -------------------------------------------------------------

class Correction:
    """A smooth correction: its values on the cells of a grid ``k`` times
    coarser that it changes, interpolated bilinearly onto the output's
    cells; zero elsewhere and on locked cells.

    Parameters
    ----------
    shape : (rows, cols)
        The output's cells.
    k : int
        The coarse grid's factor (1: the output's own cells).
    cells : ndarray of int64, shape (n,)
        Row-major indices on the coarse grid, increasing.
    values : ndarray of float64, shape (n,)
        Metres.
    locked : Mask or None
        Cells the correction leaves alone.
    """

    def __init__(self, shape: tuple[int, int], k: int, cells: np.ndarray, values: np.ndarray,
                 locked: Mask | None):
        self.shape, self.k = shape, k
        self.cshape = (-(-shape[0] // k), -(-shape[1] // k))
        self.cells, self.values, self.locked = cells, values, locked
        # The coarse rows it spans (``cells`` are row-major, increasing).
        self.rows = (int(cells[0] // self.cshape[1]), int(cells[-1] // self.cshape[1]) + 1)

    def _coarse(self, r0: int, r1: int, c0: int, c1: int) -> np.ndarray:
        """The coarse values over coarse rows r0..r1, columns c0..c1."""
        out = np.zeros((r1 - r0, c1 - c0))
        width = self.cshape[1]
        a, b = np.searchsorted(self.cells, [r0 * width, r1 * width])  # the cells of those rows
        rr, cc = np.divmod(self.cells[a:b], width)
        inside = (cc >= c0) & (cc < c1)
        out[rr[inside] - r0, cc[inside] - c0] = self.values[a:b][inside]
        return out

    def over(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """The correction over ``box`` (output cells), float64 metres."""
        r0, r1, c0, c1 = box
        if self.k == 1:
            q0, q1 = r0, r1
        else:
            # Bilinear, one axis after the other: two thin sparse matrices
            # instead of a full grid of coordinates (384 MB at 4000 x 4000),
            # cut to the box and the coarse cells it reads.
            wr = _linear_weights(self.shape[0], self.cshape[0], self.k)[r0:r1]
            q0, q1 = int(wr.indices.min()), int(wr.indices.max()) + 1
        if q1 <= self.rows[0] or q0 >= self.rows[1]:
            return np.zeros((r1 - r0, c1 - c0))  # a box the correction does not reach (a band of the map)
        if self.k == 1:
            field = self._coarse(r0, r1, c0, c1)
        else:
            wc = _linear_weights(self.shape[1], self.cshape[1], self.k)[c0:c1]
            p0, p1 = int(wc.indices.min()), int(wc.indices.max()) + 1
            field = wr[:, q0:q1] @ self._coarse(q0, q1, p0, p1) @ wc[:, p0:p1].T
        if self.locked is not None:
            field[self.locked.window(box)] = 0.0
        return field

    def apply(self, box: tuple[int, int, int, int], heights: np.ndarray) -> np.ndarray:
        """``heights`` (float32, over ``box``) with the correction added,
        in place and returned."""
        heights += self.over(box).astype(np.float32)
        return heights

    def apply_at(self, rr: np.ndarray, cc: np.ndarray, heights: np.ndarray) -> np.ndarray:
        """``heights`` (float32, at cells ``(rr, cc)``) with the correction
        added, in place and returned: :meth:`apply` cell by cell."""
        heights += self.at(rr, cc).astype(np.float32)
        return heights

    def at(self, rr: np.ndarray, cc: np.ndarray) -> np.ndarray:
        """The correction at cells ``rr, cc`` (integer arrays of one shape),
        float64 metres: what :meth:`over` gives there, to the bit."""
        rr, cc = np.asarray(rr, np.int64), np.asarray(cc, np.int64)

        def value(a, b):
            at, found = positions(self.cells, a * self.cshape[1] + b)
            return np.where(found, self.values[at], 0.0)

        if self.k == 1:
            out = value(rr, cc)
        else:
            lr, hr, tr = _linear_taps(rr, self.cshape[0], self.k)
            lc, hc, tc = _linear_taps(cc, self.cshape[1], self.k)
            # As the sparse products sum: rows first, then columns, each tap
            # in order (low, then high).
            low = (1.0 - tr) * value(lr, lc) + tr * value(hr, lc)
            high = (1.0 - tr) * value(lr, hc) + tr * value(hr, hc)
            out = (1.0 - tc) * low + tc * high
        if self.locked is not None:
            out = np.where(self.locked.at(rr, cc), 0.0, out)
        return out


def _correction(shape: tuple[int, int], chains: Sequence[tuple[np.ndarray, np.ndarray]], width: float,
                locked: Mask | None, *, tol: float, pin_zeros: bool = True, coarse: bool = True) -> Correction | None:
    """The smooth field that takes each chain's values on its cells and
    fades to zero ``width`` cells from the changed ones (None when nothing
    needs changing).

    The field is smooth on the scale of ``width``, so it is solved on a grid
    coarser by ``width // 8`` (3 for an 80-cell patch: a ninth of the
    unknowns, a twentieth of the time) and interpolated bilinearly; cells
    whose coarse neighbours are all outside the solve get exactly zero.
    Only the cells within ``width`` of a changed one are solved for, as a
    list (a long valley's band, not its bounding box).  ``pin_zeros`` False
    leaves unchanged cells free instead of holding them; ``coarse`` False
    solves on the full grid.
    """
    k = max(1, int(width // 8)) if coarse else 1
    cshape = (-(-shape[0] // k), -(-shape[1] // k))
    index, change = [], []
    for pts, ch in chains:
        r, c = _cells(pts, shape)
        keep = pin_zeros | (ch != 0)
        if locked is not None:
            keep = keep & ~locked.at(r, c)
        index.append((r[keep] // k) * cshape[1] + c[keep] // k)
        change.append(ch[keep])
    if not index:
        return None
    # Each coarse cell's pin: the mean of the changes that fall in it.
    cells, inverse = np.unique(np.concatenate(index), return_inverse=True)
    total, count = np.zeros(len(cells)), np.zeros(len(cells))
    np.add.at(total, inverse, np.concatenate(change))
    np.add.at(count, inverse, 1.0)
    value = total / np.maximum(count, 1.0)
    pinned = ~_coarse_locked(cells, cshape, k, shape, locked)
    active = pinned & (np.abs(value) > tol)
    if not active.any():
        return None
    region = _within(cells[active], width / k, cshape)
    region = region[~_coarse_locked(region, cshape, k, shape, locked)]
    field = np.zeros(len(region))
    at, found = positions(cells, region)
    is_pin = found & pinned[at]
    for members in _components(region, cshape):
        rr, cc = np.divmod(region[members], cshape[1])
        r0, c0 = int(rr.min()), int(cc.min())
        box = (int(rr.max()) + 1 - r0, int(cc.max()) + 1 - c0)
        # Solved within the component's bounding box: the Laplacian rows
        # stop at its edge.  (Added to zeros, as the dense field was.)
        field[members] += smooth_correction_cells(box, (rr - r0) * box[1] + (cc - c0), is_pin[members],
                                                 value[at[members]])
    return Correction(shape, k, region, field, locked)


def _coarse_locked(cells: np.ndarray, cshape: tuple[int, int], k: int, shape: tuple[int, int],
                   locked: Mask | None) -> np.ndarray:
    """Whether each coarse cell holds a locked cell."""
    if locked is None or len(cells) == 0:
        return np.zeros(len(cells), bool)
    r, c = np.divmod(cells, cshape[1])
    out = np.zeros(len(cells), bool)
    for dr in range(k):
        for dc in range(k):
            out |= locked.at(np.minimum(r * k + dr, shape[0] - 1), np.minimum(c * k + dc, shape[1] - 1))
    return out


#: Cells of :func:`_within`'s candidates made at a time (bounds its memory).
_WITHIN_CHUNK = 1 << 22


def _within(cells: np.ndarray, radius: float, cshape: tuple[int, int]) -> np.ndarray:
    """The grid cells closer than ``radius`` (cell centres, Euclidean) to
    one of ``cells``, row-major indices, increasing."""
    reach = int(np.ceil(radius))
    dr, dc = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    near = np.sqrt((dr * dr + dc * dc).astype(np.float64)) < radius
    dr, dc = dr[near], dc[near]
    r, c = np.divmod(cells, cshape[1])
    found = []
    step = max(1, _WITHIN_CHUNK // len(dr))
    for i in range(0, len(cells), step):
        rr = r[i:i + step, None] + dr[None, :]
        cc = c[i:i + step, None] + dc[None, :]
        inside = (rr >= 0) & (rr < cshape[0]) & (cc >= 0) & (cc < cshape[1])
        found.append(np.unique(rr[inside] * cshape[1] + cc[inside]))
    return np.unique(np.concatenate(found))


def _components(cells: np.ndarray, cshape: tuple[int, int]) -> list[np.ndarray]:
    """The 4-connected groups of ``cells`` (increasing row-major indices),
    each as positions into ``cells``."""
    n = len(cells)
    r, c = np.divmod(cells, cshape[1])
    edges_a, edges_b = [], []
    for step, same_row in ((1, True), (cshape[1], False)):
        at, found = positions(cells, cells + step)
        link = found & ((c + 1 < cshape[1]) if same_row else (r + 1 < cshape[0]))
        edges_a.append(np.flatnonzero(link))
        edges_b.append(at[link])
    a, b = np.concatenate(edges_a), np.concatenate(edges_b)
    graph = sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    order = np.argsort(labels, kind="stable")
    return np.split(order, np.flatnonzero(np.diff(labels[order])) + 1)


def _linear_taps(x: np.ndarray, m: int, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cells ``x`` on a grid of ``m`` coarse cells of ``k`` cells each: the
    low and high coarse cells and the high one's weight (as
    :func:`_linear_weights`)."""
    t = np.clip((x + 0.5) / k - 0.5, 0.0, m - 1)
    lo = np.minimum(np.floor(t).astype(np.int64), max(m - 2, 0))
    return lo, np.minimum(lo + 1, m - 1), t - lo


def _linear_weights(n: int, m: int, k: int) -> sparse.csr_matrix:
    """Linear interpolation from ``m`` coarse cells of ``k`` cells each onto
    ``n`` cells (centres aligned, clamped at the ends), shape (n, m)."""
    lo, hi, t = _linear_taps(np.arange(n), m, k)
    rows = np.repeat(np.arange(n), 2)
    cols = np.stack([lo, hi], axis=1).ravel()
    return sparse.csr_matrix((np.stack([1.0 - t, t], axis=1).ravel(), (rows, cols)), shape=(n, m))
