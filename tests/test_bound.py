"""The forward dynamic program of placement.planning.program.forward against enumeration of every sequence.

Oracle: all-pairs shortest paths by scipy's Dijkstra on an independently built graph, then every
sequence of (cell, group) of small random tasks enumerated, keeping each place's group equal to
its pick's; the minimum total must equal the program's, and the chain it returns must cost that.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra
from support.navigation import grid_graph

from placement.planning.program.forward import Program, Regions, backtrack, cheapest, forward

RES = 0.1
GROUPS = (("left", "top"), ("right", "top"), ("right", "side"))


def random_task(rng, ny, nx, steps, linked):
    feasible = rng.random((ny, nx)) > 0.2
    factor = 1.0 + 3.0 * rng.random((ny, nx))
    start = tuple(int(v) for v in np.argwhere(feasible)[0])
    regions = []
    for i in range(steps):
        groups = GROUPS if not (i > 0 and linked[i]) else GROUPS[::-1]  # another order: groups match by name
        masks = (rng.random((len(groups), ny, nx)) > 0.85) & feasible
        node = rng.random((len(groups), ny, nx)) * 0.3 if i % 2 else None
        regions.append(Regions.of(groups, masks, node))
    return factor, feasible, start, regions


def enumerate_best(factor, feasible, start, regions, linked):
    """The least total over every sequence of (group, cell), by brute force."""
    ny, nx = feasible.shape
    dist = dijkstra(grid_graph(factor, feasible, RES))
    choices = []
    for reg in regions:
        choices.append(
            [
                (reg.groups[g], int(f), reg.node_at(g, int(f)))
                for g in range(len(reg.groups))
                for f in np.flatnonzero(reg.dense()[g])
            ]
        )
    best = math.inf
    s = start[0] * nx + start[1]
    for seq in itertools.product(*choices):
        if any(linked[i] and seq[i][0] != seq[i - 1][0] for i in range(1, len(seq))):
            continue
        total, at = 0.0, s
        for _group, f, node in seq:
            total += dist[at, f] + node
            at = f
        best = min(best, total)
    return best, dist


@pytest.mark.parametrize("seed", range(6))
def test_the_program_equals_enumeration_of_every_sequence(seed):
    rng = np.random.default_rng(seed)
    linked = [False, True, False] if seed % 2 == 0 else [False, False, True]
    factor, feasible, start, regions = random_task(rng, 6, 7, 3, linked)
    want, dist = enumerate_best(factor, feasible, start, regions, linked)
    layers = forward(factor, feasible, RES, start, regions, linked)
    got = float(layers[-1].labels.min())
    if math.isinf(want):
        assert math.isinf(got)
        assert backtrack(layers, regions, linked) is None
        return
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12)
    chain = backtrack(layers, regions, linked)
    assert chain is not None and chain.total == pytest.approx(want, rel=1e-9)
    # the chain stands on its regions, keeps the linked groups, and its legs add up to its total
    nx = feasible.shape[1]
    at, total = start[0] * nx + start[1], 0.0
    for i, (f, g) in enumerate(zip(chain.cells, chain.groups)):
        assert regions[i].dense()[g].flat[f]
        if linked[i]:
            assert regions[i].groups[g] == regions[i - 1].groups[chain.groups[i - 1]]
        total += dist[at, f] + regions[i].node_at(g, f)
        assert chain.labels[i] == pytest.approx(total, rel=1e-9)
        at = f


def test_recomputing_from_a_step_equals_a_fresh_program():
    rng = np.random.default_rng(11)
    linked = [False, True, False, True]
    factor, feasible, start, regions = random_task(rng, 8, 8, 4, linked)
    layers = forward(factor, feasible, RES, start, regions, linked)
    masks = regions[2].dense()
    masks[:, :4] = False  # a repair removes cells of step 2
    changed = [*regions[:2], Regions.of(regions[2].groups, masks), regions[3]]
    again = forward(factor, feasible, RES, start, changed, linked, layers, first=2)
    fresh = forward(factor, feasible, RES, start, changed, linked)
    for a, b in zip(again, fresh):
        np.testing.assert_array_equal(a.labels, b.labels)


def test_a_place_with_no_group_of_its_pick_is_unreachable():
    #   a 1 x 5 corridor: the pick only by the left arm, the place only by the right
    factor, feasible = np.ones((1, 5)), np.ones((1, 5), bool)
    pick = Regions.of((("left", "top"),), np.array([[[0, 1, 0, 0, 0]]], bool))
    place = Regions.of((("right", "top"),), np.array([[[0, 0, 0, 1, 0]]], bool))
    layers = forward(factor, feasible, RES, (0, 0), [pick, place], [False, True])
    assert np.isinf(layers[-1].labels).all()
    # unlinked, the same cells cost 0.1 m then 0.2 m more
    layers = forward(factor, feasible, RES, (0, 0), [pick, place], [False, False])
    assert float(layers[-1].labels.min()) == pytest.approx(0.3)


@pytest.mark.parametrize("seed", range(8))
def test_the_relaxed_program_gives_the_grouped_optimum_or_defers_to_it(seed):
    """cheapest(): the relaxed program (groups merged) with groups given after, else the grouped one;
    its chain keeps every transfer's group and costs the enumerated optimum."""
    rng = np.random.default_rng(100 + seed)
    linked = [False, True, False, True]
    factor, feasible, start, regions = random_task(rng, 6, 6, 4, linked)
    regions = [Regions.of(r.groups, r.dense()) for r in regions]  # no node costs: the relaxation applies
    want, dist = enumerate_best(factor, feasible, start, regions, linked)
    chain, _ = cheapest(factor, feasible, RES, start, regions, linked)
    if math.isinf(want):
        assert chain is None
        return
    assert chain is not None and chain.total == pytest.approx(want, rel=1e-9)
    nx = feasible.shape[1]
    at, total = start[0] * nx + start[1], 0.0
    for i, (f, g) in enumerate(zip(chain.cells, chain.groups)):
        assert regions[i].dense()[g].flat[f]
        if linked[i]:
            assert regions[i].groups[g] == regions[i - 1].groups[chain.groups[i - 1]]
        total += dist[at, f]
        at = f
    assert total == pytest.approx(want, rel=1e-9)


def test_the_relaxed_chain_that_breaks_a_transfer_is_not_taken():
    #   a 1 x 5 corridor from cell 0: the left arm picks at 1, the right arm at 4; the place at 2
    #   is the right arm's: the relaxed chain (1, 2) costs 0.2 m but breaks the transfer, the
    #   grouped optimum is (4, 2): 0.4 m + 0.2 m with the right arm
    factor, feasible = np.ones((1, 5)), np.ones((1, 5), bool)
    pick = Regions.of((("left", "top"), ("right", "top")), np.array([[[0, 1, 0, 0, 0]], [[0, 0, 0, 0, 1]]], bool))
    place = Regions.of((("right", "top"),), np.array([[[0, 0, 1, 0, 0]]], bool))
    chain, _ = cheapest(factor, feasible, RES, (0, 0), [pick, place], [False, True])
    assert chain is not None and chain.total == pytest.approx(0.6)
    assert pick.groups[chain.groups[0]] == ("right", "top") and chain.cells == [4, 2]
    #   the place at 0 after a pick at 1 only by the left arm: no chain keeps the rule
    place = Regions.of((("right", "top"),), np.array([[[1, 0, 0, 0, 0]]], bool))
    pick = Regions.of((("left", "top"),), np.array([[[0, 1, 0, 0, 0]]], bool))
    assert cheapest(factor, feasible, RES, (0, 0), [pick, place], [False, True])[0] is None


def test_a_lazy_program_groups_a_transfer_whose_pick_cell_has_no_group_of_the_place():
    #   a 1 x 5 corridor from cell 0: the left arm picks at 1, the right arm at 3; the place at 2 is
    #   the right arm's only. The relaxed chain (1, 2) conflicts and its pick cell has no group the
    #   place has, so even the lazy program (global's) groups the transfer: (3, 2), 0.3 + 0.1 m
    factor, feasible = np.ones((1, 5)), np.ones((1, 5), bool)
    pick = Regions.of((("left", "top"), ("right", "top")), np.array([[[0, 1, 0, 0, 0]], [[0, 0, 0, 1, 0]]], bool))
    place = Regions.of((("right", "top"),), np.array([[[0, 0, 1, 0, 0]]], bool))
    program = Program(factor, feasible, RES, (0, 0), [False, True])
    program.lazy = True
    chain = program.solve([pick, place])
    assert chain is not None and chain.cells == [3, 2] and chain.total == pytest.approx(0.4)
    assert pick.groups[chain.groups[0]] == place.groups[chain.groups[1]] == ("right", "top")
    assert program.loose == []
    #   the place also by the left arm, at 4: the conflict's pick cell (1, left) has a group the
    #   place has, so the lazy program keeps the cheap cells and marks the place loose with the
    #   left arm (global then moves it to the left arm's cell); the grouped one solves it exactly
    place = Regions.of((("left", "top"), ("right", "top")), np.array([[[0, 0, 0, 0, 1]], [[0, 0, 1, 0, 0]]], bool))
    program = Program(factor, feasible, RES, (0, 0), [False, True])
    program.lazy = True
    chain = program.solve([pick, place])
    assert chain is not None and chain.cells == [1, 2] and program.loose == [1]
    assert place.groups[chain.groups[1]] == pick.groups[chain.groups[0]] == ("left", "top")
    exact, _ = cheapest(factor, feasible, RES, (0, 0), [pick, place], [False, True])
    assert exact is not None and exact.total == pytest.approx(0.4)  # (1, 4) left or (3, 2) right
