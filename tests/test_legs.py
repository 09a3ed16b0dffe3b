"""The travel legs the whole-task repairs and the task-time pass read (``StepProblems.legs``, cached)
against scipy's Dijkstra on an independently built graph, both ways."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.sparse.csgraph import dijkstra
from support.navigation import grid_graph

from placement.planning import Planner

SCENE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing_obstacles.yaml"


def test_legs_equal_dijkstra_both_ways(tiny_maps):
    planner = Planner(SCENE, "global", tiny_maps)
    problems, w = planner.problems, planner.world
    rng = np.random.default_rng(4)
    free = np.argwhere(w.feasible)
    graph = grid_graph(w.factor, w.feasible, w.nav.resolution)
    for _ in range(3):
        before, after = (tuple(int(v) for v in free[rng.integers(len(free))]) for _ in range(2))
        targets = np.flatnonzero(w.feasible & (rng.random(w.feasible.shape) < 0.05))
        into, out_of = problems.legs(before, targets), problems.legs(after, targets, reverse=True)
        nx = w.nav.shape[1]
        from_before = dijkstra(graph, indices=before[0] * nx + before[1])
        to_after = dijkstra(graph.T.tocsr(), indices=after[0] * nx + after[1])
        assert into.shape == out_of.shape == targets.shape
        np.testing.assert_allclose(into, from_before[targets], rtol=1e-9)
        np.testing.assert_allclose(out_of, to_after[targets], rtol=1e-9)
        # asked again: the cached legs
        np.testing.assert_array_equal(problems.legs(before, targets), into)
        np.testing.assert_array_equal(problems.legs(after, targets, reverse=True), out_of)
        assert np.isfinite(into).sum() > 10
