"""The inverse-map kernel in a background thread (``placement.planning.problems.background``): options a
program prefetched, their kernel passes run while the next step's arguments are made, equal those
computed in place, bit for bit; a call's exception reaches whoever waits for it."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from placement.planning import Planner
from placement.planning.problems import background, cache

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "table_clearing.yaml"


def test_a_call_runs_in_the_background_thread_and_its_error_reaches_the_wait(tiny_maps):
    Planner(SCENE, "global", tiny_maps)  # warm: numba chooses its threading layer
    if not background.concurrent():
        pytest.skip("numba's threading layer here does not take kernels from two threads")
    where: list[str] = []
    wait = background.behind(lambda: where.append(threading.current_thread().name))
    wait()
    assert where == [where[0]] and where[0].startswith("placement-kernel")

    def fails() -> None:
        raise ValueError("bad slice")

    wait = background.behind(fails)
    with pytest.raises(ValueError, match="bad slice"):
        wait()
    here: list[str] = []
    background.behind(lambda: here.append(threading.current_thread().name), background=False)
    assert here == [threading.current_thread().name]  # not in the background: run where it is called


@pytest.mark.parametrize("exact", [False, True], ids=["threshold", "exact"])
def test_prefetched_options_equal_those_computed_in_place(tiny_maps, monkeypatch, exact):
    """Every step of a scene, prefetched all at once (the kernel passes queued behind each
    other) and then read, against a planner that computes them when asked: the same options, windows,
    values and yaws."""
    monkeypatch.setattr(cache, "THRESHOLD_PASS_FROM", 1)  # threshold passes on every step
    ahead = Planner(SCENE, "global", tiny_maps).problems
    plain = Planner(SCENE, "global", tiny_maps).problems
    steps = range(len(ahead.steps))
    for i in steps:
        ahead.prefetch(i, None, exact)  # every torso setting
    assert len(ahead._pending) >= len(ahead.steps)  # started, not yet read
    compared = 0
    for i in steps:
        got = ahead.options(i) if exact else ahead.threshold_options(i)
        want = plain.options(i) if exact else plain.threshold_options(i)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert (g.arm, g.candidate.grasp, g.window, g.blocked, g.exact) == (
                w.arm,
                w.candidate.grasp,
                w.window,
                w.blocked,
                w.exact,
            )
            np.testing.assert_array_equal(g.value, w.value)
            np.testing.assert_array_equal(g.yaw_index, w.yaw_index)
            compared += int((w.value > 0).sum())
    assert not ahead._pending  # every started pass was read
    assert compared > 1000


def test_a_step_by_step_plan_prefetches_the_next_steps_and_plans_the_same(tiny_maps, monkeypatch):
    """A step-by-step method (``sequential``; the others plan their steps alike) starts the kernel passes of the steps after the current one: a plan with
    them started equals one that computes each step's options when asked, and the passes it started
    were all read."""
    from placement.planning.methods import stepwise

    scene = ROOT / "examples" / "buildings" / "wrs_arena" / "tidy_up_ycb.yaml"
    started: list[tuple[int, bool]] = []  # (step, in the background) of every pass launched
    launch = cache.StepProblems._launch_options

    def counting(self, step, torso, regional, stop, background=True):
        started.append((step.index, background))
        return launch(self, step, torso, regional, stop, background)

    monkeypatch.setattr(cache.StepProblems, "_launch_options", counting)
    ahead = Planner(scene, "sequential", tiny_maps)
    first = ahead.plan()
    # the later steps' passes were started in the background, and every one started was read
    assert {i for i, bg in started if bg} >= {1, 2} and not ahead.problems._pending
    monkeypatch.setattr(stepwise, "PREFETCH_AHEAD", 0)
    second = Planner(scene, "sequential", tiny_maps).plan()
    assert [
        (s.status, getattr(s, "arm", None), getattr(s, "base", None), getattr(s, "reason", None)) for s in first.steps
    ] == [
        (s.status, getattr(s, "arm", None), getattr(s, "base", None), getattr(s, "reason", None)) for s in second.steps
    ]
