"""Certificates and the whole-task methods on real maps: the bound against brute force over the maps'
cells, the bound below every method's travel, ``optimal`` never worse than ``sequential``.

Oracle: the regions read from the options' manipulation maps directly, all-pairs shortest paths by
scipy's Dijkstra on an independently built graph, and every sequence of (cell, arm and grasp)
enumerated (a place keeps its pick's arm and grasp).
"""

from __future__ import annotations

import itertools
import json
import math

import numpy as np
import pytest
from scipy.sparse.csgraph import dijkstra
from support.navigation import grid_graph
from support.planning import write_scene

from placement.planning import METHODS, Planner
from placement.planning.methods.optimal import DynamicProgram, solve_verified
from placement.planning.task_time import task_time

COARSE = {"resolution": 0.2, "task": [{"pick": "cup", "place": "spot"}]}


def oracle_regions(planner):
    """Per step: {(arm, grasp): set of flat cells} where an option keeps its arm's threshold."""
    out = []
    for i in range(len(planner.problems.steps)):
        groups: dict = {}
        for o in planner.problems.options(i):
            full = o.full_value(planner.world.nav.shape) >= planner.thresholds[o.arm]
            groups.setdefault((o.arm, o.candidate.grasp), set()).update(np.flatnonzero(full & planner.world.feasible))
        out.append(groups)
    return out


def brute_force(planner, regions, dist):
    nx = planner.world.nav.shape[1]
    sy, sx = planner.start_cell()
    steps = planner.problems.steps
    choices = [[(g, c) for g, cells in reg.items() for c in cells] for reg in regions]
    best = math.inf
    for seq in itertools.product(*choices):
        if any(steps[i].pick == i - 1 and seq[i][0] != seq[i - 1][0] for i in range(1, len(seq))):
            continue
        at, total = sy * nx + sx, 0.0
        for _, c in seq:
            total += dist[at, c]
            at = c
        best = min(best, total)
    return best


@pytest.fixture(scope="module")
def coarse(maps_dir, tmp_path_factory):
    path = write_scene(tmp_path_factory.mktemp("coarse"), maps_dir, **COARSE)
    return Planner(path, "optimal", maps_dir, collisions=False)


def test_the_bound_equals_brute_force_over_the_maps_cells(coarse):
    w = coarse.world
    dist = dijkstra(grid_graph(w.factor, w.feasible, w.nav.resolution))
    regions = oracle_regions(coarse)
    assert all(regions) and sum(len(c) for reg in regions for c in reg.values()) > 10
    want = brute_force(coarse, regions, dist)
    result = coarse.plan()
    assert result.certificate.lower_bound_s == pytest.approx(want / coarse.robot.v_max, rel=1e-6)


def test_optimal_equals_brute_force_over_the_cells_left_after_its_repairs(coarse):
    w = coarse.world
    dist = dijkstra(grid_graph(w.factor, w.feasible, w.nav.resolution))
    dp = DynamicProgram(coarse.context, coarse.start_cell())
    chain, picks, failure = solve_verified(dp)
    assert failure is None and chain is not None and len(picks) == len(coarse.problems.steps)
    # the cells the program ended with: the maps' less those its verification rejected
    nx = w.nav.shape[1]
    left = oracle_regions(coarse)
    for i, reg in enumerate(left):
        for k, g in enumerate(dp.regions[i].groups):
            reg[g] = {c for c in reg[g] if dp.regions[i].has(k, c)}
        assert sum(map(len, reg.values())) == int(dp.regions[i].masks.sum())
    assert chain.total == pytest.approx(brute_force(coarse, left, dist), rel=1e-9)
    result = coarse.plan()
    travel = sum(s.travel_time_s for s in result.steps) * coarse.robot.v_max
    assert travel == pytest.approx(chain.total, rel=1e-9)
    assert all(s.ok for s in result.steps) and not result.verify(coarse.robot)
    del nx


@pytest.fixture(scope="module")
def every_method(maps_dir, tmp_path_factory):
    path = write_scene(tmp_path_factory.mktemp("methods"), maps_dir)
    planner = Planner(path, "sequential", maps_dir)
    out = {}
    for m in METHODS:
        planner.set_method(m)
        out[m] = planner.plan()
    return planner, out


@pytest.mark.slow
def test_every_plan_carries_a_certificate_in_its_json(every_method):
    planner, results = every_method
    for m, r in results.items():
        doc = json.loads(json.dumps(r.to_json()))
        cert = doc["certificate"]
        assert set(cert) == {"lower_bound_s", "travel_s", "gap", "task_time_s", "task_gap", "regions", "timings_ms"}, m
        assert cert["regions"] == ("fixed placements" if m == "fixed" else "maps")
        if r.ok:
            assert cert["travel_s"] == pytest.approx(sum(s["travel_time_s"] for s in doc["steps"]), abs=1e-5)


def test_the_bound_is_below_every_methods_travel(every_method):
    planner, results = every_method
    planned = [m for m, r in results.items() if r.ok]
    assert {"sequential", "global", "optimal"} <= set(planned)
    for m in planned:
        cert = results[m].certificate
        assert cert is not None and cert.travel_s is not None and cert.task_time_s is not None
        assert cert.lower_bound_s <= cert.travel_s + 1e-6, m
        assert cert.gap is not None and cert.gap >= -1e-6, m
        # a step lasts at least its travel: the bound is below the task time too, which the model counts
        assert cert.task_time_s == pytest.approx(
            task_time(planner.robot, results[m], planner.scene.start)["total_s"], abs=1e-5
        )
        assert cert.task_gap is not None
        assert cert.travel_s <= cert.task_time_s + 1e-6 and cert.task_gap >= cert.gap - 1e-6, m


def test_optimal_is_never_worse_than_sequential(every_method):
    _, results = every_method
    assert results["optimal"].certificate.travel_s <= results["sequential"].certificate.travel_s + 1e-6
    assert results["global"].ok and not results["global"].verify(every_method[0].robot)


@pytest.mark.slow
def test_each_step_of_the_whole_task_methods_travels_the_shortest_path_from_the_last(every_method):
    """A chain repaired locally (``global``) keeps exact legs: each step's travel is scipy's shortest
    path from the previous base cell (the start for the first)."""
    planner, results = every_method
    w = planner.world
    dist = dijkstra(grid_graph(w.factor, w.feasible, w.nav.resolution))
    nx = w.nav.shape[1]
    v_max = planner.robot.v_max
    for m in ("global", "optimal"):
        at = planner.start_cell()
        for s in results[m].steps:
            here = w.nav.cell(s.base[0], s.base[1])
            want = dist[at[0] * nx + at[1], here[0] * nx + here[1]] / v_max
            assert s.travel_time_s == pytest.approx(want, rel=1e-6, abs=1e-6), (m, s.index)
            at = here
