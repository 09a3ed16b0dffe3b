"""Shortest paths *to* a cell (the reversed grid, used by the default method's local repair) against
scipy's Dijkstra on the transposed graph, and a literal row."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra
from support.navigation import grid_graph

from placement.planning.world.navigation import navigation_cost


def test_a_row_to_its_first_cell():
    # factors 1 2 3 4 along a row of 1 m cells; to cell 0 a path pays the factors of the cells it
    # enters: 3 -> 2 -> 1 -> 0 costs 3 + 2 + 1; from cell 0 it is 2, 2 + 3, 2 + 3 + 4
    factor = np.array([[1.0, 2.0, 3.0, 4.0]])
    feasible = np.ones((1, 4), bool)
    to, pred = navigation_cost(factor, feasible, (0, 0), 1.0, reverse=True)
    assert to.tolist() == [[0.0, 1.0, 3.0, 6.0]]
    assert pred.tolist() == [[-1, 0, 1, 2]]  # the next cell towards the target
    out, _ = navigation_cost(factor, feasible, (0, 0), 1.0)
    assert out.tolist() == [[0.0, 2.0, 5.0, 9.0]]


@pytest.mark.parametrize("seed", range(12))
def test_reverse_costs_equal_dijkstra_on_the_transposed_graph(seed):
    rng = np.random.default_rng(seed)
    ny, nx = rng.integers(3, 14, size=2)
    factor = 1.0 + 3.0 * rng.random((ny, nx))
    feasible = rng.random((ny, nx)) > 0.25
    target = tuple(int(v) for v in np.argwhere(feasible)[rng.integers(feasible.sum())])
    res = 0.05
    got, pred = navigation_cost(factor, feasible, target, res, reverse=True)
    want = dijkstra(grid_graph(factor, feasible, res).T.tocsr(), indices=target[0] * nx + target[1]).reshape(ny, nx)
    want[~feasible] = np.inf
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # following pred from any reached cell walks to the target at exactly its cost
    G = grid_graph(factor, feasible, res).tocsr()
    for flat in np.flatnonzero(np.isfinite(got)):
        total, at = 0.0, int(flat)
        while pred.flat[at] >= 0:
            nxt = int(pred.flat[at])
            total += G[at, nxt]
            at = nxt
        assert at == target[0] * nx + target[1]
        assert total == pytest.approx(got.flat[flat], rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_reverse_with_targets_is_exact_on_them(seed):
    rng = np.random.default_rng(100 + seed)
    ny, nx = 12, 15
    factor = 1.0 + rng.random((ny, nx))
    feasible = rng.random((ny, nx)) > 0.2
    cells = np.argwhere(feasible)
    target = tuple(int(v) for v in cells[0])
    wanted = np.zeros((ny, nx), bool)
    wanted[tuple(cells[rng.integers(len(cells), size=5)].T)] = True
    full, _ = navigation_cost(factor, feasible, target, 0.1, reverse=True)
    part, _ = navigation_cost(factor, feasible, target, 0.1, targets=wanted, reverse=True)
    np.testing.assert_array_equal(part[wanted], full[wanted])
