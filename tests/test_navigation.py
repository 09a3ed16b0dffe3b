"""Navigation kernels against scipy (EDT, Dijkstra) and tiny literal grids."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra
from support.navigation import S2, grid_graph

from placement.errors import PlacementError
from placement.planning.world.navigation import costs_at, distance_map, extract_path, navigation_cost, speed_factor


@pytest.mark.parametrize("seed", range(5))
def test_distance_map_matches_scipy(seed):
    rng = np.random.default_rng(seed)
    ny, nx = rng.integers(5, 70, size=2)
    occ = rng.random((ny, nx)) < rng.uniform(0.01, 0.3)
    occ[0, 0] = True
    got = distance_map(occ, 0.05)
    want = ndimage.distance_transform_edt(~occ) * 0.05
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_distance_map_empty_is_inf():
    assert np.isinf(distance_map(np.zeros((3, 4), bool), 0.1)).all()


def test_speed_factor_literal():
    d = np.array([0.0, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(speed_factor(d, 1.3, 4, 1.0), [1 + 1.3, 1 + 1.3 * 0.5**4, 1.0, 1.0])


@pytest.mark.parametrize("seed", range(5))
def test_costs_equal_scipy_dijkstra(seed):
    rng = np.random.default_rng(100 + seed)
    ny, nx = rng.integers(4, 40, size=2)
    feas = rng.random((ny, nx)) > 0.25
    fac = speed_factor(distance_map(~feas, 0.05), 1.3, 4, 1.0)
    starts = np.argwhere(feas)[rng.choice(feas.sum(), size=2, replace=False)]
    cost, _ = navigation_cost(fac, feas, starts, 0.05)
    ref = dijkstra(grid_graph(fac, feas, 0.05), indices=starts[:, 0] * nx + starts[:, 1], min_only=True)
    ref = ref.reshape(ny, nx)
    assert np.array_equal(np.isinf(cost), np.isinf(ref))
    np.testing.assert_allclose(cost[np.isfinite(ref)], ref[np.isfinite(ref)], rtol=1e-12, atol=0)


def test_tiny_literal_grid():
    # 5 x 5, resolution 1 m, factor 1, start S, wall # (not enterable):
    #   row 4: . . . . .
    #   row 3: . # # # .
    #   row 2: . . S # .
    #   row 1: . # # # .
    #   row 0: . . . . .
    feas = np.ones((5, 5), bool)
    for y, x in [(3, 1), (3, 2), (3, 3), (2, 3), (1, 1), (1, 2), (1, 3)]:
        feas[y, x] = False
    cost, pred = navigation_cost(np.ones((5, 5)), feas, (2, 2), 1.0)
    inf = np.inf
    # west 1, then diagonal around the wall ends, then along rows 0 / 4, down column 4
    expected = np.array(
        [
            [2 + S2, 1 + 2 * S2, 2 + 2 * S2, 3 + 2 * S2, 4 + 2 * S2],  # row 0
            [1 + S2, inf, inf, inf, 3 + 3 * S2],  # row 1
            [2, 1, 0, inf, 4 + 3 * S2],  # row 2
            [1 + S2, inf, inf, inf, 3 + 3 * S2],  # row 3
            [2 + S2, 1 + 2 * S2, 2 + 2 * S2, 3 + 2 * S2, 4 + 2 * S2],  # row 4
        ]
    )
    np.testing.assert_allclose(cost, expected, rtol=1e-12)
    path = extract_path(pred, (2, 4))
    assert tuple(path[0]) == (2, 2) and tuple(path[-1]) == (2, 4)
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    assert sum(S2 if s == 2 else 1.0 for s in steps) == pytest.approx(cost[2, 4])


def test_start_in_obstacle_is_an_error():
    feas = np.ones((3, 3), bool)
    feas[1, 1] = False
    with pytest.raises(PlacementError, match="inside an obstacle"):
        navigation_cost(np.ones((3, 3)), feas, (1, 1), 0.05)


@pytest.mark.parametrize("seed", range(3))
def test_early_stop_is_exact_on_targets(seed):
    rng = np.random.default_rng(200 + seed)
    feas = rng.random((50, 60)) > 0.2
    fac = speed_factor(distance_map(~feas, 0.05), 1.3, 4, 1.0)
    start = np.argwhere(feas)[0]
    full, _ = navigation_cost(fac, feas, start, 0.05)
    targets = np.zeros_like(feas)
    targets[rng.integers(0, 50, 15), rng.integers(0, 60, 15)] = True
    part, pred = navigation_cost(fac, feas, start, 0.05, targets=targets)
    sel = targets & feas
    assert np.array_equal(part[sel], full[sel])
    assert np.all(np.isinf(part[~np.isfinite(full)]))
    assert np.all((part == full) | np.isinf(part))  # unsettled cells are reported as inf, never wrong


@pytest.mark.parametrize("seed", range(4))
def test_start_costs_and_predecessors(seed):
    """Sources with different start costs (a virtual super-source in scipy's graph) and uniform
    factors (many equal-cost paths): costs equal scipy's, and every predecessor lies on a shortest
    path (cost[v] = cost[pred] + edge, exactly as the search added it)."""
    rng = np.random.default_rng(300 + seed)
    ny, nx = rng.integers(5, 40, size=2)
    feas = rng.random((ny, nx)) > 0.2
    fac = np.ones((ny, nx)) if seed % 2 else speed_factor(distance_map(~feas, 0.05), 1.3, 4, 1.0)
    starts = np.argwhere(feas)[rng.choice(feas.sum(), size=3, replace=False)]
    start_costs = rng.uniform(0, 2.0, 3)
    cost, pred = navigation_cost(fac, feas, starts, 0.05, start_costs=start_costs)
    g = grid_graph(fac, feas, 0.05).tolil()
    g.resize((ny * nx + 1, ny * nx + 1))
    for (y, x), c in zip(starts, start_costs):
        g[ny * nx, y * nx + x] = c
    ref = dijkstra(g.tocsr(), indices=ny * nx)[:-1].reshape(ny, nx)
    assert np.array_equal(np.isinf(cost), np.isinf(ref))
    np.testing.assert_allclose(cost[np.isfinite(ref)], ref[np.isfinite(ref)], rtol=1e-12, atol=0)
    for v in np.flatnonzero(pred.ravel() >= 0):
        u = pred.flat[v]
        (vy, vx), (uy, ux) = divmod(v, nx), divmod(u, nx)
        step = 0.05 * (S2 if vy != uy and vx != ux else 1.0)
        assert max(abs(vy - uy), abs(vx - ux)) == 1
        assert cost.flat[v] == cost.flat[u] + step * fac[vy, vx]


@pytest.mark.parametrize("seed", range(6))
def test_directed_search_is_exact_on_a_box_of_targets(seed):
    """With targets the search heads for their bounding box (A* keys, :data:`GUIDE`): from several
    sources with start costs, forward and on the reversed graph, uniform (many ties) or varying
    slowdowns, the targets' costs equal scipy's Dijkstra, and each settled cell's predecessor lies on
    a shortest path."""
    rng = np.random.default_rng(600 + seed)
    ny, nx = rng.integers(8, 45, size=2)
    feas = rng.random((ny, nx)) > 0.15
    fac = np.ones((ny, nx)) if seed % 2 else speed_factor(distance_map(~feas, 0.05), 1.3, 4, 1.0)
    reverse = seed >= 3
    starts = np.argwhere(feas)[rng.choice(feas.sum(), size=2, replace=False)]
    start_costs = rng.uniform(0, 1.0, 2)
    y0, x0 = rng.integers(0, ny - 3), rng.integers(0, nx - 3)
    targets = np.zeros_like(feas)
    targets[y0 : y0 + rng.integers(1, 6), x0 : x0 + rng.integers(1, 8)] = True
    cost, pred = navigation_cost(fac, feas, starts, 0.05, start_costs, targets, reverse=reverse)
    g = grid_graph(fac, feas, 0.05)
    g = (g.T if reverse else g).tolil()
    g.resize((ny * nx + 1, ny * nx + 1))
    for (y, x), c in zip(starts, start_costs):
        g[ny * nx, y * nx + x] = c
    ref = dijkstra(g.tocsr(), indices=ny * nx)[:-1].reshape(ny, nx)
    sel = targets & feas
    assert np.array_equal(np.isinf(cost[sel]), np.isinf(ref[sel]))
    np.testing.assert_allclose(cost[sel & np.isfinite(ref)], ref[sel & np.isfinite(ref)], rtol=1e-12, atol=0)
    for v in np.flatnonzero(pred.ravel() >= 0):
        u = pred.flat[v]
        (vy, vx), (uy, ux) = divmod(v, nx), divmod(u, nx)
        step = 0.05 * (S2 if vy != uy and vx != ux else 1.0)
        entered = (uy, ux) if reverse else (vy, vx)
        assert cost.flat[v] == cost.flat[u] + step * fac[entered]


def test_directed_search_leaves_the_far_side_unsearched():
    """An open 40 x 40 grid, the source in the middle, one target cell at the east edge: a plain
    Dijkstra settles every cell nearer than the target (about pi r^2 of them), the directed search
    hardly any cell west of the source."""
    feas = np.ones((40, 40), bool)
    targets = np.zeros_like(feas)
    targets[20, 39] = True
    cost, _ = navigation_cost(np.ones((40, 40)), feas, (20, 20), 0.1, targets=targets)
    assert cost[20, 39] == pytest.approx(1.9, abs=1e-12)
    assert np.isfinite(cost[:, :20]).sum() < 60  # a plain search settles all 800 west-side cells


def _frozen_copy(a):
    a = a.copy()
    a.flags.writeable = False
    return a


@pytest.mark.parametrize("seed", range(6))
def test_costs_at_targets_equal_the_whole_maps_in_any_order_of_searches(seed):
    """costs_at (the targets' costs and path sources only, on kept work arrays for read-only grids)
    against navigation_cost's (ny, nx) maps and scipy's Dijkstra, over a random sequence of searches
    (sources, targets, reverse) on the same grids: a search leaves nothing behind for the next one,
    and the kept work arrays come back as they were."""
    from placement.planning.world import navigation as nav

    rng = np.random.default_rng(1200 + seed)
    ny, nx = (int(v) for v in rng.integers(4, 30, size=2))
    feas = rng.random((ny, nx)) > 0.25
    fac = speed_factor(distance_map(~feas, 0.05), 1.3, 4, 1.0)
    grids = [(fac, feas), (_frozen_copy(fac), _frozen_copy(feas))]  # made per search / kept
    dist = dijkstra(grid_graph(fac, feas, 0.05))
    for _ in range(12):
        k = int(rng.integers(1, 4))
        starts = np.argwhere(feas)[rng.choice(feas.sum(), size=k, replace=False)]
        at = rng.choice(ny * nx, size=int(rng.integers(1, 12)), replace=False)
        reverse = bool(rng.integers(0, 2))
        targets = np.zeros((ny, nx), bool)
        targets.flat[at] = True
        want, pred = navigation_cost(fac, feas, starts, 0.05, targets=targets, reverse=reverse)
        for f, m in grids:
            cost, source = costs_at(f, m, starts, 0.05, at, reverse=reverse)
            np.testing.assert_array_equal(cost, want.flat[at])
            ref = [
                int(extract_path(pred, divmod(int(c), nx))[0] @ [nx, 1]) if np.isfinite(want.flat[c]) else int(c)
                for c in at
            ]
            assert source.tolist() == ref
        flat_starts = starts[:, 0] * nx + starts[:, 1]
        oracle = dist[flat_starts][:, at].min(axis=0) if not reverse else dist[at][:, flat_starts].min(axis=1)
        finite = np.isfinite(oracle)
        assert np.array_equal(np.isfinite(want.flat[at]), finite)
        np.testing.assert_allclose(want.flat[at][finite], oracle[finite], rtol=1e-12)
    assert nav._kept.grids
    for _, _, grid, work in nav._kept.grids.values():
        cost, prev, open_, tgt, root = work
        assert np.isinf(cost).all() and (prev == -1).all() and np.array_equal(open_, grid[1])
        assert not tgt.any() and (root == -1).all()


def test_costs_at_literal_corridor():
    #   a 1 x 5 corridor searched from cell 1 towards cells 4 and 0; cell 3 blocked in the second grid
    cost, source = costs_at(np.ones((1, 5)), np.ones((1, 5), bool), [(0, 1)], 0.1, np.array([4, 0]))
    np.testing.assert_allclose(cost, [0.3, 0.1])
    assert source.tolist() == [1, 1]
    blocked = np.array([[True, True, True, False, True]])
    cost, source = costs_at(np.ones((1, 5)), blocked, [(0, 1)], 0.1, np.array([4, 2]))
    assert np.isinf(cost[0]) and cost[1] == pytest.approx(0.1)
    assert source.tolist() == [4, 1]  # unreached: the cell itself
    assert costs_at(np.ones((1, 5)), blocked, [(0, 1)], 0.1, np.zeros(0, np.int64))[0].size == 0
    with pytest.raises(PlacementError, match="outside"):
        costs_at(np.ones((1, 5)), blocked, [(0, 1)], 0.1, np.array([5]))


EIGHT = np.ones((3, 3), dtype=bool)


@pytest.mark.parametrize("seed", range(6))
def test_components_equal_scipy_labels_and_boxes(seed):
    """Against ``scipy.ndimage.label`` (3 x 3 structure) and ``find_objects`` on random masks of any
    density: the same labels in the same raster order, the same boxes."""
    from placement.kernels.navigation import components8

    rng = np.random.default_rng(seed)
    for _ in range(40):
        ny, nx = (int(v) for v in rng.integers(1, 30, 2))
        mask = rng.random((ny, nx)) < rng.uniform(0.05, 0.95)
        want, n = ndimage.label(mask, structure=EIGHT)
        labels, boxes = components8(mask)
        assert np.array_equal(labels, want) and len(boxes) == n
        got = [(slice(int(a), int(b)), slice(int(c), int(d))) for a, b, c, d in boxes]
        assert got == ndimage.find_objects(want)


def test_components_literal():
    # 4 x 6 mask; diagonal neighbours join (8-connected):
    #   X . . X X .
    #   . X . . . .
    #   . . . . . X
    #   X X . . X .
    mask = np.array([[1, 0, 0, 1, 1, 0], [0, 1, 0, 0, 0, 0], [0, 0, 0, 0, 0, 1], [1, 1, 0, 0, 1, 0]], dtype=bool)
    from placement.kernels.navigation import component_of, components8

    labels, boxes = components8(mask)
    assert labels.tolist() == [[1, 0, 0, 2, 2, 0], [0, 1, 0, 0, 0, 0], [0, 0, 0, 0, 0, 3], [4, 4, 0, 0, 3, 0]]
    assert boxes.tolist() == [[0, 2, 0, 2], [0, 1, 3, 5], [2, 4, 4, 6], [3, 4, 0, 2]]
    assert component_of(mask, 3, 4).tolist() == (labels == 3).tolist()
    assert not component_of(mask, 0, 1).any()  # off the mask: nothing


@pytest.mark.parametrize("seed", range(4))
def test_the_component_of_a_cell_is_its_scipy_label(seed):
    from placement.kernels.navigation import component_of

    rng = np.random.default_rng(100 + seed)
    mask = rng.random((40, 35)) < 0.6
    labels, _ = ndimage.label(mask, structure=EIGHT)
    for y, x in rng.integers(0, 35, (20, 2)):
        want = labels == labels[y, x] if mask[y, x] else np.zeros_like(mask)
        assert np.array_equal(component_of(mask, int(y), int(x)), want)
