"""Poisson seam removal: the paper's flat step and its C1 variant."""

import numpy as np
import pytest
from scipy import ndimage

from terrasynth_core.blending.poisson import remove_seam
from terrasynth_core.errors import ParamsError

SHAPE = (40, 48)
SEAM_COL = 24
STEP = 50.0


@pytest.fixture
def grid():
    rr, cc = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]]
    return rr.astype(np.float64), cc.astype(np.float64)


@pytest.fixture
def take_new():
    return np.broadcast_to(np.arange(SHAPE[1]) >= SEAM_COL, SHAPE).copy()


def _left_column():
    fixed = np.zeros(SHAPE, bool)
    fixed[:, 0] = True
    return fixed


def _jump(h):
    return np.abs(h[:, SEAM_COL].astype(np.float64) - h[:, SEAM_COL - 1]).max()


def test_poisson_removes_a_step_between_two_planes(grid, take_new):
    rr, cc = grid
    plane = 1200.0 + 0.4 * rr + 0.05 * cc
    composite = (plane + STEP * take_new).astype(np.float32)
    before = composite.copy()
    fixed = _left_column()
    out = remove_seam(composite, take_new, np.ones(SHAPE, bool), fixed=fixed)

    assert out.dtype == np.float32
    assert _jump(composite) > STEP
    assert _jump(out) < 0.01 * STEP
    np.testing.assert_array_equal(out[fixed], composite[fixed])
    np.testing.assert_array_equal(composite, before)
    # Away from the seam the planes' own slopes survive.
    np.testing.assert_allclose(np.diff(out[:, 30:], axis=0), 0.4, atol=1e-3)


def test_step_is_spread_when_both_sides_are_fixed(grid, take_new):
    rr, cc = grid
    composite = (300.0 + 0.2 * rr + STEP * take_new).astype(np.float32)
    fixed = np.zeros(SHAPE, bool)
    fixed[:, [0, -1]] = True
    out = remove_seam(composite, take_new, ~fixed, fixed=fixed)
    np.testing.assert_array_equal(out[fixed], composite[fixed])
    # The 50 m difference between the fixed sides becomes a ramp: no cliff.
    # Every column step, the seam's included, is the same share of it.
    np.testing.assert_allclose(np.diff(out.astype(np.float64), axis=1), STEP / (SHAPE[1] - 1), rtol=1e-4)


def test_c1_keeps_slope_continuity_better_than_poisson(grid, take_new):
    _, cc = grid
    composite = (100.0 + 2.0 * cc + 30.0 * take_new).astype(np.float32)
    region = np.ones(SHAPE, bool)
    fixed = _left_column()
    results = {mode: remove_seam(composite, take_new, region, fixed=fixed, mode=mode) for mode in ("poisson", "c1")}

    def crease(h):
        h = h.astype(np.float64)
        return np.abs(np.diff(h[:, SEAM_COL - 3 : SEAM_COL + 3], n=2, axis=1)).max()

    assert crease(results["poisson"]) > 1.5  # the paper's flat step: slope 2 -> 0 -> 2
    assert crease(results["c1"]) < 0.01
    for out in results.values():
        assert _jump(out) < 0.05 * 30.0 + 2.0


def test_unanchored_region_is_returned_unchanged(grid, take_new):
    _, cc = grid
    composite = (cc + STEP * take_new).astype(np.float32)
    out = remove_seam(composite, take_new, np.ones(SHAPE, bool))  # default fixed: nothing
    np.testing.assert_array_equal(out, composite)

    # Two free islands, only one touching a fixed pixel: only that one moves.
    region = np.zeros(SHAPE, bool)
    region[5:15, 10:40] = True
    region[25:35, 10:40] = True
    fixed = np.zeros(SHAPE, bool)
    fixed[5:15, 9] = True
    out = remove_seam(composite, take_new, region, fixed=fixed)
    unchanged = ~region | (np.arange(SHAPE[0]) >= 20)[:, None]
    np.testing.assert_array_equal(out[unchanged], composite[unchanged])
    assert _jump(out[5:15]) < 0.01 * STEP


def test_a_solid_block_is_anchored_only_by_a_side_neighbour(grid, take_new):
    _, cc = grid
    composite = (cc + STEP * take_new).astype(np.float32)
    region = np.zeros(SHAPE, bool)
    region[10:30, 10:40] = True
    corners = np.zeros(SHAPE, bool)
    corners[[9, 9, 30, 30], [9, 40, 9, 40]] = True  # diagonal neighbours only
    out = remove_seam(composite, take_new, region, fixed=corners)
    np.testing.assert_array_equal(out, composite)
    for r, c in ((9, 20), (30, 20), (20, 9), (20, 40)):  # one beside each side in turn
        fixed = corners.copy()
        fixed[r, c] = True
        out = remove_seam(composite, take_new, region, fixed=fixed)
        assert _jump(out[10:30]) < 0.01 * STEP


def test_pixels_outside_region_and_fixed_are_a_neumann_border(grid, take_new):
    rr, cc = grid
    composite = (0.5 * rr + STEP * take_new).astype(np.float32)
    composite[:, -4:] = np.nan  # no terrain there, neither region nor fixed
    region = np.ones(SHAPE, bool)
    region[:, -4:] = False
    fixed = _left_column()
    out = remove_seam(composite, take_new, region, fixed=fixed)
    assert np.isnan(out[:, -4:]).all()
    assert _jump(out) < 0.01 * STEP


def test_cached_factorization_does_not_leak_heights(grid, take_new):
    rr, cc = grid
    region = np.ones(SHAPE, bool)
    fixed = _left_column()
    first = remove_seam((rr + STEP * take_new).astype(np.float32), take_new, region, fixed=fixed)
    second_input = (2.0 * cc - STEP * take_new).astype(np.float32)
    second = remove_seam(second_input, take_new, region, fixed=fixed)
    assert not np.allclose(first, second)
    np.testing.assert_array_equal(second[fixed], second_input[fixed])
    assert _jump(second) < 0.01 * STEP + 2.0


def test_bad_arguments_raise(take_new):
    heights = np.zeros(SHAPE, np.float32)
    with pytest.raises(ParamsError, match="mode"):
        remove_seam(heights, take_new, np.ones(SHAPE, bool), mode="laplace")
    with pytest.raises(ParamsError, match="region"):
        remove_seam(heights, take_new, np.ones((3, 3), bool))
    bad = heights.copy()
    bad[5, 30] = np.nan
    with pytest.raises(ParamsError, match="non-finite"):
        remove_seam(bad, take_new, np.ones(SHAPE, bool), fixed=_left_column())


def test_rectangle_solver_equals_sparse_factorization_on_mixed_borders():
    """The fast solve of a solid block (sine transforms plus the open
    border edges by Woodbury) is the sparse LU's answer, whatever pattern of
    fixed and open neighbours surrounds it, clipped borders included."""
    from terrasynth_core.blending import poisson
    from terrasynth_core.blending.rectangle import open_edges, rectangle_solver

    rng = np.random.default_rng(7)
    for _ in range(40):
        H, W = (int(v) for v in rng.integers(3, 30, 2))
        known = rng.random((H, W)) < rng.uniform(0.1, 0.9)
        free = np.zeros((H, W), bool)
        r0, c0 = int(rng.integers(0, 2)), int(rng.integers(0, 2))  # 0: block touches the grid's edge
        free[r0:H - 1, c0:W - 1] = True
        known &= ~free
        if not (ndimage.binary_dilation(known) & free).any():
            continue
        index = np.full((H, W), -1)
        index[free] = np.arange(int(free.sum()))
        take = free | known
        down = take[:-1] & take[1:] & (free[:-1] | free[1:])
        right = take[:, :-1] & take[:, 1:] & (free[:, :-1] | free[:, 1:])
        p = np.concatenate([index[:-1][down], index[:, :-1][right]])
        q = np.concatenate([index[1:][down], index[:, 1:][right]])
        rhs = rng.normal(size=int(free.sum()))
        solver = rectangle_solver((H - 1 - r0, W - 1 - c0))
        fast = solver.solve(rhs, *solver.capacitance(open_edges((r0, H - 1, c0, W - 1), known)))
        sparse_lu = poisson._laplacian_solver(free, known, p, q).solve(rhs)
        np.testing.assert_allclose(fast, sparse_lu, rtol=0, atol=1e-9 * np.abs(sparse_lu).max())


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (2, 5), (3, 3), (7, 2), (14, 80), (41, 23)])
def test_rim_green_matrix_is_the_inverse_laplacian_between_rim_cells(shape):
    """The rim's Green's matrix, read from the sine basis, equals the
    all-fixed block's inverse Laplacian applied to each rim cell's unit
    vector, for thin and square blocks alike."""
    from terrasynth_core.blending.rectangle import RectangleSolver

    solver = RectangleSolver(shape)
    units = np.zeros((solver.rim.size, shape[0] * shape[1]))
    units[np.arange(solver.rim.size), solver.rim] = 1.0
    columns = np.stack([solver._fixed_solve(u.reshape(shape)).ravel()[solver.rim] for u in units])
    np.testing.assert_allclose(solver._green, columns, rtol=0, atol=1e-12 * np.abs(columns).max())


def test_a_block_with_a_rim_beyond_the_cap_is_factorized():
    """A solver's Green's matrix grows with its rim squared: blocks past
    MAX_RIM (none the engine makes) go to the sparse LU, with the same answer."""
    from terrasynth_core.blending.rectangle import MAX_RIM, rectangle_solver

    assert rectangle_solver((80, 80)) is not None
    long = (1, MAX_RIM // 2 + 2)
    assert rectangle_solver(long) is None
    heights = np.zeros((3, long[1] + 2), np.float32)
    heights[1, 1:-1] = np.linspace(0.0, 5.0, long[1])
    take_new = np.zeros(heights.shape, bool)
    take_new[:, heights.shape[1] // 2:] = True
    region = np.zeros(heights.shape, bool)
    region[1, 1:-1] = True
    out = remove_seam(heights, take_new, region, fixed=~region)
    assert np.isfinite(out).all() and not np.array_equal(out, heights)
    np.testing.assert_array_equal(out[~region], heights[~region])
