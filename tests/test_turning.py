"""The task-time passes of the whole-task methods (placement.planning.program.turning): the yaw
sequence is exact against brute force, and on the real building maps the default's task time with
them is never longer than without, every plan still verifies, `optimal` keeps its travel, and the
certificate's bound stays below the task time."""

from __future__ import annotations

import dataclasses
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from placement.planning import Planner
from placement.planning.program.turning import CHANGE_COST_S, best_yaws
from placement.planning.task_time import task_time
from placement.scene import load_scene

BUILDINGS = sorted((Path(__file__).resolve().parents[1] / "examples" / "buildings").glob("*/tidy_up.yaml"))


def sequence_seconds(start, travel, arm, cands, choice, omega):
    """The objective of best_yaws, written out: each step's max(travel, turn / omega, arm), plus the
    tie cost of a changed yaw."""
    total, prev = 0.0, start
    for t, a, c, j in zip(travel, arm, cands, choice):
        turn = abs(math.remainder(c[j] - prev, 2 * math.pi))
        total += max(t, turn / omega, a) + (CHANGE_COST_S if j else 0.0)
        prev = c[j]
    return total


@settings(max_examples=200, deadline=None)
@given(
    st.integers(1, 4).flatmap(
        lambda n: st.tuples(
            st.floats(-math.pi, math.pi),
            st.lists(st.floats(0, 3), min_size=n, max_size=n),
            st.lists(st.floats(0, 2), min_size=n, max_size=n),
            st.lists(st.lists(st.floats(-math.pi, math.pi), min_size=1, max_size=4), min_size=n, max_size=n),
            st.floats(0.2, 3.0),
        )
    )
)
def test_the_yaw_sequence_is_the_least_of_all(args):
    start, travel, arm, cands, omega = args
    cands = [np.array(c) for c in cands]
    choice = best_yaws(start, travel, arm, cands, omega)
    assert len(choice) == len(cands) and all(0 <= j < len(c) for j, c in zip(choice, cands))
    got = sequence_seconds(start, travel, arm, cands, choice, omega)
    brute = min(
        sequence_seconds(start, travel, arm, cands, combo, omega)
        for combo in itertools.product(*(range(len(c)) for c in cands))
    )
    assert got == pytest.approx(brute, abs=1e-9)


def test_a_tie_keeps_the_verified_yaws():
    # the second candidate turns as far the other way: same time, so the kept yaw (index 0) stays
    assert best_yaws(0.0, [1.0, 1.0], [0.0, 0.0], [np.array([0.5, -0.5]), np.array([0.0, 1.0])], 1.0) == [0, 0]


def plan(path, maps_dir, method, polish):
    scene = load_scene(path)
    scene = dataclasses.replace(scene, planner={**scene.planner, "time_polish": polish, "time_budget_s": 3600})
    planner = Planner(scene, method, maps_dir)
    result = planner.plan()
    assert result.ok, result.failed_step
    assert result.verify(planner.robot, scene=planner.scene) == []
    return planner, result, task_time(planner.robot, result, planner.scene.start)["total_s"]


@pytest.mark.slow
@pytest.mark.parametrize("path", BUILDINGS, ids=lambda p: p.parent.name)
def test_the_default_with_the_passes_takes_no_longer(path, maps_dir):
    planner, polished, t1 = plan(path, maps_dir, "global", 1)
    _, plain, t0 = plan(path, maps_dir, "global", 0)
    assert t1 <= t0 + 1e-9
    cert = polished.certificate
    assert cert is not None and cert.travel_s is not None
    assert cert.task_time_s == pytest.approx(t1, abs=1e-5)
    assert cert.lower_bound_s <= cert.travel_s + 1e-6 and cert.lower_bound_s <= t1 + 1e-6
    assert cert.task_gap == pytest.approx(t1 / cert.lower_bound_s - 1, abs=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("path", BUILDINGS, ids=lambda p: p.parent.name)
def test_optimal_turns_but_keeps_its_cells(path, maps_dir):
    _, turned, t1 = plan(path, maps_dir, "optimal", 1)
    _, plain, t0 = plan(path, maps_dir, "optimal", 0)
    assert [s.base[:2] for s in turned.steps] == [s.base[:2] for s in plain.steps]
    assert t1 <= t0 + 1e-9


@pytest.mark.slow
def test_more_rounds_of_the_passes_take_no_longer(maps_dir, monkeypatch):
    """The passes run again while a round shortens the task: on the regression scene where a second
    round pays (the footprint PR2), three rounds give a shorter task than one, verified; and never a
    longer one on the building scenes."""
    import placement.planning.methods.optimal as optimal

    scenes = [Path(__file__).parent / "data" / "regression" / "small_default_threshold.yaml", *BUILDINGS]
    shorter = 0
    for path in scenes:
        monkeypatch.setattr(optimal, "POLISH_ROUNDS", 1)
        _, _, once = plan(path, maps_dir, "global", 1)
        monkeypatch.setattr(optimal, "POLISH_ROUNDS", 3)
        _, _, thrice = plan(path, maps_dir, "global", 1)
        assert thrice <= once + 1e-9, path
        shorter += thrice < once - 1e-6
    assert shorter >= 1


@pytest.mark.slow
def test_a_step_searched_again_with_what_it_read_before_is_skipped_and_the_plan_is_the_same(maps_dir, monkeypatch):
    """``time_cells`` skips a step whose search would read what it read when it last found nothing
    (its key in ``settled``): on the building scenes the plans equal those that search every step in
    every round, and steps were skipped."""
    import placement.planning.methods.optimal as optimal
    from placement.planning.program import turning

    searched = turning.time_cells
    skipped = 0

    def counting(dp, chain, picks, steps, settled=None):
        nonlocal skipped
        keys = dict(settled or {})
        out = searched(dp, chain, picks, steps, settled)
        skipped += sum(1 for i, k in keys.items() if (settled or {}).get(i) == k)
        return out

    plans = {}
    for name, wrapper in (
        ("skipping", counting),
        ("every step", lambda dp, c, p, s, settled=None: searched(dp, c, p, s)),
    ):
        monkeypatch.setattr(optimal, "time_cells", wrapper)
        plans[name] = [
            [(s.arm, s.grasp, tuple(s.base)) for s in Planner(path, "global", maps_dir).plan().steps]
            for path in BUILDINGS
        ]
    assert plans["skipping"] == plans["every step"]
    assert skipped >= 1
