"""``global`` drops a (step, group) that verifies nowhere (``DynamicProgram.hopeless``) instead of taking
the program through its region cell by cell, and forgets the cells a failed repair rejected.

The kitchen's lying can is the case: its grasp along the can's axis (``side-+z``) puts a finger into
the table at the pick and the forearm into the counter's edge at the place wherever the base stands,
though the gripper alone stays within the screen's slack (an IK solution's tolerance) and the maps,
which know the arm alone, hold hundreds of cells for it. Before the probe, ``global`` verified 763
placements there (2,265 on the tiny maps) and took 7-14 s; every cell of those groups is rejected."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from support.budgets import unbudgeted

from placement.planning import Planner, load_scene
from placement.planning.methods.optimal import DynamicProgram, solve_verified
from placement.planning.program import state
from placement.planning.program.regions import Regions
from placement.planning.program.state import PROBE_AFTER, PROBE_SECTORS

KITCHEN = Path(__file__).resolve().parents[1] / "examples" / "kitchen.yaml"
LYING_CAN = (3, 4)  # pick can_lying, place it on the counter


@pytest.fixture(scope="module")
def solved(tiny_maps):
    """The kitchen's ``global`` program (as the method sets it up), solved and verified."""
    planner = Planner(unbudgeted(load_scene(KITCHEN)), "global", tiny_maps)
    ctx = planner.context
    dp = DynamicProgram(ctx, planner.start_cell(), 1, ctx.config.global_exact_repairs)
    dp.local = dp.program.lazy = True
    return planner, dp, solve_verified(dp)


def test_the_kitchen_plans_with_the_lying_cans_axis_grasp_dropped(solved):
    planner, dp, (chain, picks, failure) = solved
    assert failure is None and chain is not None and len(picks) == len(planner.problems.steps)
    dropped = {(i, group) for i, group, _ in dp.dropped}
    for arm in ("left", "right"):
        assert {(i, (arm, "side-+z")) for i in LYING_CAN} <= dropped
    # the chain stands on no dropped group
    # (the plan's steps are checked independently in test_plans_on_tiny_maps)
    assert not {(i, dp.regions[i].groups[g]) for i, g in enumerate(chain.groups)} & dropped


def test_every_cell_of_a_dropped_group_is_rejected(solved):
    """The probe's verdict checked against every cell the maps give the group (the pick's left arm)."""
    _, dp, _ = solved
    i = LYING_CAN[0]
    full = dp.full[i]
    k = full.groups.index(("left", "side-+z"))
    cells = full.cells[full.masks[k]]
    assert cells.size > 100
    g = dp.regions[i].groups.index(("left", "side-+z"))
    assert all(dp.verify(i, int(flat), g) is None for flat in cells)


def test_a_group_that_verified_is_never_hopeless(solved):
    _, dp, (chain, _, _) = solved
    i, g = 0, chain.groups[0]
    key = (i, dp.regions[i].groups[g], dp.setting(i, g))
    assert dp.settled[key] is True
    dp.tally[key] = dp.tally.get(key, set()) | set(range(-PROBE_AFTER, 0))
    checked = len(dp.verified)
    assert not dp.hopeless(i, g)
    assert len(dp.verified) == checked


def test_fewer_rejections_than_the_trigger_verify_nothing(solved):
    _, dp, _ = solved
    i = 6
    reg = dp.regions[i]
    fresh = [g for g in range(len(reg.groups)) if (i, reg.groups[g], dp.setting(i, g)) not in dp.settled]
    assert fresh
    g = fresh[0]
    key = (i, reg.groups[g], dp.setting(i, g))
    before = dp.tally.get(key)
    dp.tally[key] = set(range(PROBE_AFTER - 1))
    checked = len(dp.verified)
    try:
        assert not dp.hopeless(i, g)
        assert len(dp.verified) == checked and key not in dp.settled
    finally:
        if before is None:
            del dp.tally[key]
        else:
            dp.tally[key] = before


def test_probe_cells_are_each_sectors_best_cell(solved):
    """Against a plain loop: a cell per non-empty sector of angle about the region's mean cell, the
    one of the highest map value (the first of equals by cell order)."""
    _, dp, _ = solved
    for i in range(len(dp.regions)):
        reg = dp.regions[i]
        for g in range(len(reg.groups)):
            cells = reg.cells[reg.masks[g]]
            if not cells.size:
                assert dp.probe_cells(i, g) == []
                continue
            members = [o for o in dp.options(i, g) if (o.arm, o.candidate.grasp) == reg.groups[g]]
            values = dp.ctx.problems.exact_values(members, cells)[0].max(axis=0)
            nx = reg.shape[1]
            cy = sum(int(c) // nx for c in cells) / cells.size
            cx = sum(int(c) % nx for c in cells) / cells.size
            best: dict[int, tuple[float, int]] = {}
            for c, v in zip(cells.tolist(), values.tolist()):
                a = math.atan2(c // nx - cy, c % nx - cx)
                s = min(int((a + math.pi) / (2 * math.pi) * PROBE_SECTORS), PROBE_SECTORS - 1)
                if s not in best or v > best[s][0]:
                    best[s] = (v, c)
            assert dp.probe_cells(i, g) == [best[s][1] for s in sorted(best)]


def test_without_cells_turns_off_the_named_cells_only():
    # cells 1, 4, 7, 9 of a 2 x 5 grid; group 0 holds all, group 1 the last two
    reg = Regions(
        (("left", "a"), ("right", "a")), np.array([1, 4, 7, 9]), np.array([[1, 1, 1, 1], [0, 0, 1, 1]], bool), (2, 5)
    )
    out = reg.without_cells({0: [4, 8, 1], 1: [9, 0]})  # 8 and 0 are not cells: ignored
    assert out.masks.tolist() == [[False, False, True, True], [False, False, True, False]]
    assert reg.masks.all(axis=1).tolist() == [True, False]  # the original is unchanged
    assert out.without_group(0).masks.tolist() == [[False] * 4, [False, False, True, False]]


def test_forget_rejected_removes_the_rejected_cells_of_that_step_alone(solved):
    _, dp, _ = solved
    i = LYING_CAN[1]
    reg = dp.regions[i]
    dp.forget_rejected(i)
    for (step, flat, group, hold), v in dp.verified.items():
        if step == i and v is None and group in reg.groups:
            g = reg.groups.index(group)
            if dp.setting(i, g) == hold:
                assert not dp.regions[i].has(g, flat)
    kept = reg.masks & ~dp.regions[i].masks
    for g, k in zip(*np.nonzero(kept)):
        key = (i, int(reg.cells[k]), reg.groups[g], dp.setting(i, int(g)))
        assert key in dp.verified and dp.verified[key] is None


@pytest.mark.slow
def test_optimal_takes_a_hopeless_groups_rejections_in_threes_for_the_same_optimum(tiny_maps, monkeypatch):
    """``optimal`` verifies the 3 x 3 cells around a rejection of a group rejected at
    :data:`PROBE_AFTER` cells and verified at none, removing the rejected ones: fewer solves, and the
    same optimum as removing one cell per solve (only rejected cells leave either way)."""
    whole = unbudgeted(load_scene(KITCHEN))
    scene = replace(whole, task=(whole.task[2],))  # the lying can's transfer alone

    def solved():
        planner = Planner(scene, "optimal", tiny_maps)
        ctx = planner.context
        # exact throughout (no neighbourhoods removed unverified after ``optimal_max_repairs``)
        dp = DynamicProgram(ctx, planner.start_cell(), 1, None, priced=True)
        chain, picks, failure = solve_verified(dp)
        assert failure is None and chain is not None and len(picks) == len(planner.problems.steps)
        return dp, chain

    dp, chain = solved()
    monkeypatch.setattr(state, "PROBE_AFTER", 10**9)  # one cell per solve
    one_by_one, reference = solved()
    assert chain.total == pytest.approx(reference.total, rel=1e-12)
    assert dp.solves < one_by_one.solves


def test_a_repair_stops_at_a_group_its_probe_gives_up(tiny_maps, monkeypatch):
    """A repair of one group (a transfer's) verifies no cell of it after ``gives_up`` said the probe
    found none (the kitchen's lying can on the tiny maps: repairs that end so do occur); the plan
    still plans."""
    import importlib

    import placement.planning.methods.optimal as optimal

    repair_module = importlib.import_module("placement.planning.program.repair")
    real = repair_module.repair
    stopped = []

    def watched(dp, chain, i):
        calls: list[tuple[str, int, bool]] = []
        verify, gives_up = dp.verify, dp.gives_up

        def v(step, flat, g):
            out = verify(step, flat, g)
            calls.append(("verify", g, out is not None))
            return out

        def up(step, g, late=False, after=PROBE_AFTER):
            out = gives_up(step, g, late, after)
            calls.append(("gives_up", g, out))
            return out

        dp.verify, dp.gives_up = v, up
        try:
            out = real(dp, chain, i)
        finally:
            del dp.verify, dp.gives_up
        given = {g for what, g, said in calls if what == "gives_up" and said}
        for g in given:
            at = next(k for k, c in enumerate(calls) if c == ("gives_up", g, True))
            # the probe's own verifications come before its verdict; none after it
            assert not any(what == "verify" and gg == g for what, gg, _ in calls[at + 1 :])
        stopped.extend(given)
        return out

    monkeypatch.setattr(optimal, "repair", watched)
    scene = unbudgeted(load_scene(KITCHEN))
    plan = Planner(scene, "global", tiny_maps).plan()
    assert stopped, "the scene must exercise a repair that gives a group up"
    assert plan.ok


def test_a_groups_members_are_its_options_in_order(solved):
    """Against a plain scan: each group's option indices, per options list (cached per list)."""
    _, dp, _ = solved
    for i in range(len(dp.regions)):
        reg = dp.regions[i]
        for g, group in enumerate(reg.groups):
            opts = dp.options(i, g)
            want = [k for k, o in enumerate(opts) if (o.arm, o.candidate.grasp) == group]
            assert dp.members(opts, group) == want
            assert dp.members(list(opts), group) == want  # another list of the same options
    assert dp.members([], ("left", "no such grasp")) == []
