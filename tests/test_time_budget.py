"""The task's time budget, run out at every point a method checks it (a clock that counts the checks,
not seconds, so the test does not depend on the machine): each method returns the steps it verified
before (each one verifying independently) and then the first step not verified, saying which budget
ran out and how to raise it; never a traceback, never a step without its placement. The certificate
is cut by the same budget and says so."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
from support.budgets import unbudgeted

from placement.planning import Planner, load_scene
from placement.planning.context import PlanningContext

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "table_clearing_obstacles.yaml"


class CountingClock:
    """``out_of_budget`` that answers True from its ``after``-th call on (0: at once)."""

    def __init__(self, after: int):
        self.after, self.calls = after, 0

    def __call__(self, ctx: PlanningContext) -> bool:
        self.calls += 1
        return ctx.deadline is not None and self.calls > self.after


def install(monkeypatch, clock: CountingClock) -> None:
    monkeypatch.setattr(PlanningContext, "out_of_budget", lambda ctx: clock(ctx))


@pytest.fixture(scope="module")
def planners(tiny_maps):
    scene = load_scene(SCENE)
    scene = unbudgeted(scene)
    return {m: Planner(scene, m, tiny_maps) for m in ("global", "optimal", "sequential", "irm")}


def _checks(planner, monkeypatch) -> int:
    clock = CountingClock(10**9)
    install(monkeypatch, clock)
    assert planner.plan().ok
    return clock.calls


@pytest.mark.parametrize("method", ["global", pytest.param("optimal", marks=pytest.mark.slow), "sequential", "irm"])
def test_the_budget_spent_at_any_check_keeps_a_verified_partial_plan(planners, method, monkeypatch):
    planner = planners[method]
    calls = _checks(planner, monkeypatch)
    assert calls > 0
    # check points spread over a whole plan (12: a check point in each of the plan's phases, which
    # these scenes take a few dozen checks through), the first and the last
    for after in sorted({round(k * calls / 12) for k in range(12)} | {0, 1, calls - 1}):
        install(monkeypatch, CountingClock(after))
        result = planner.plan()
        problems = result.verify(planner.robot, scene=planner.scene)
        assert problems == [], (after, problems)
        if result.ok:
            continue
        failed = result.failed_step
        assert failed is result.steps[-1] and all(s.ok for s in result.steps[:-1]), after
        assert [s.step for s in result.steps] == list(range(len(result.steps))), after
        assert "time budget of 3600 s ran out" in failed.reason and "planner.time_budget_s" in failed.reason, (
            after,
            failed.reason,
        )
        doc = json.loads(json.dumps(result.to_json()))
        assert doc["steps"][-1]["status"] == "infeasible"


def test_a_certificate_cut_by_the_budget_says_so(planners, monkeypatch):
    """``sequential``'s bound is a program of its own after the plan: with the budget spent there, the
    plan stands and the certificate has no bound and says why (JSON ``stopped``)."""
    planner = planners["sequential"]
    start = planner.start_cell()
    planner.plan()
    bound = planner.problems.bounds[("maps", start)]
    clock = CountingClock(10**9)
    install(monkeypatch, clock)
    planner.plan()  # the bound kept from the first plan: only the plan's own checks
    plan_checks = clock.calls
    del planner.problems.bounds[("maps", start)]
    install(monkeypatch, CountingClock(plan_checks))
    result = planner.plan()
    assert result.ok
    cert = result.to_json()["certificate"]
    assert cert["lower_bound_s"] is None and cert["gap"] is None and cert["task_gap"] is None
    assert "time budget of 3600 s ran out" in cert["stopped"]
    monkeypatch.undo()
    assert planner.plan().certificate.lower_bound_s * planner.robot.v_max == pytest.approx(bound)


class GrowingMemory:
    """``resident_gib`` that reports the process as grown by 1 TiB from its ``after``-th reading on."""

    def __init__(self, after: int):
        self.after, self.calls = after, 0

    def __call__(self) -> float:
        self.calls += 1
        return 1.0 if self.calls <= self.after else 1024.0


@pytest.mark.parametrize("method", ["global", "sequential"])
def test_the_memory_budget_spent_at_any_check_keeps_a_verified_partial_plan(planners, method, monkeypatch):
    """The memory budget (``memory_budget_gib`` added to the resident memory at the plan's start) is
    checked where the time budget is: run out at readings spread over a plan, the method keeps the
    steps verified before and says which budget ran out and how to raise it."""
    import placement.planning.context as context
    import placement.planning.planner as planner_module

    planner = planners[method]
    meter = GrowingMemory(10**9)
    monkeypatch.setattr(context, "resident_gib", meter)
    monkeypatch.setattr(planner_module, "resident_gib", meter)
    assert planner.plan().ok
    readings = meter.calls
    assert readings > 1  # the plan's start, then its checks
    for after in sorted({1 + round(k * (readings - 1) / 8) for k in range(8)}):
        meter = GrowingMemory(after)
        monkeypatch.setattr(context, "resident_gib", meter)
        monkeypatch.setattr(planner_module, "resident_gib", meter)
        result = planner.plan()
        assert result.verify(planner.robot, scene=planner.scene) == [], after
        if result.ok:
            continue
        failed = result.failed_step
        assert failed is result.steps[-1] and all(s.ok for s in result.steps[:-1]), after
        assert "memory budget of 3 GiB ran out" in failed.reason and "planner.memory_budget_gib" in failed.reason, (
            after,
            failed.reason,
        )


def test_a_plan_past_its_memory_budget_at_once_stops_at_its_first_step(planners):
    """The process's real resident memory (``/proc/self/statm``) against a limit below it: the first
    step is not planned, saying the memory budget ran out."""
    import placement.planning.context as context

    if context.resident_gib() is None:
        pytest.skip("no /proc/self/statm here: the memory budget does not apply")
    planner = planners["sequential"]
    ctx = replace(planner.context, memory_limit=0.001, spent=[])
    steps = planner.method.plan(ctx, planner.start_cell(), False)
    assert len(steps) == 1 and not steps[0].ok
    assert "memory budget of 3 GiB ran out" in steps[0].reason


def test_the_time_a_query_spent_building_its_planner_counts_against_its_budget(planners, monkeypatch):
    """``plan(spent_s=...)`` gives the plan what is left of the budget: with all of it spent the plan
    stops at its first check (the first step says the budget ran out); ``placement.plan`` and the
    query charge the planner's construction (``construction_s``, measured), and a planner kept for
    more plans gives each the whole budget."""
    import time

    from placement.planning import planner as planner_module

    planner = planners["sequential"]
    assert planner.construction_s > 0
    spent = planner.plan(spent_s=3600.0)
    assert not spent.ok and "time budget of 3600 s ran out" in spent.steps[0].reason
    assert planner.plan().ok  # the next plan: the whole budget again
    asked = []
    real = planner_module.Planner.plan

    def recording(self, keep_maps=False, spent_s=0.0):
        asked.append((spent_s, self.construction_s))
        return real(self, keep_maps, spent_s)

    monkeypatch.setattr(planner_module.Planner, "plan", recording)
    t = time.perf_counter()
    assert planner_module.plan(unbudgeted(load_scene(SCENE)), "sequential", planner.map_path).ok
    assert len(asked) == 1 and asked[0][0] == asked[0][1] and 0 < asked[0][0] < time.perf_counter() - t


def test_compiling_kernels_is_not_counted_against_a_task(tiny_maps, monkeypatch):
    """A cold kernel cache (the first query after an install) compiles for tens of seconds: the clock
    counts compilations, and only them, and both a planner's construction and a query leave its time
    out of the task's budget."""
    from numba import njit

    import placement.cli as cli
    from placement.compile_clock import compile_seconds
    from placement.planning import planner as planner_module

    before = compile_seconds()

    @njit
    def fresh(x: float) -> float:  # compiled at its first call, here
        return x * 2.0 + 1.0

    assert fresh(1.0) == 3.0
    compiled = compile_seconds() - before
    assert compiled > 0.0
    fresh(2.0)  # compiled already: nothing more
    assert compile_seconds() - before == compiled

    # a clock that says 1000 s of compiling happened while the planner was built
    ticks = iter([0.0, 1000.0])
    monkeypatch.setattr(planner_module, "compile_seconds", lambda: next(ticks))
    assert Planner(SCENE, "global", tiny_maps).construction_s < -900.0
    # a query run inside this program counts from its own start, less what compiled since
    import time

    began = time.perf_counter() - 2.0
    spent = cli.spent_s(began, compile_seconds())
    assert 2.0 + cli.RESERVE_S <= spent < 2.0 + cli.RESERVE_S + 1.0
