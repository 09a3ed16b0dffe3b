"""The whole-task program's options that say only where each keeps its threshold
(``StepProblems.threshold_options``: the kernel stops at the first yaw keeping it) hold the same regions
as the exact options, and ``exact_values`` gives every cell's best value and yaw as the exact options
hold them: a plan verifies the same cells in the same order with either."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from placement.planning import Planner
from placement.planning.problems import cache

ROOT = Path(__file__).resolve().parents[1]
SCENES = [ROOT / "examples" / "table_clearing.yaml", ROOT / "examples" / "buildings" / "wrs_arena" / "tidy_up_ycb.yaml"]


def _same(o):
    """What an option and its threshold-only twin share."""
    return o.arm, o.candidate.grasp, o.torso, o.window, o.blocked


@pytest.mark.parametrize("scene", SCENES, ids=lambda p: p.stem)
def test_threshold_options_keep_the_exact_regions_values_and_yaws(tiny_maps, scene, monkeypatch):
    monkeypatch.setattr(cache, "THRESHOLD_PASS_FROM", 1)  # every step, however few its candidates
    rough = Planner(scene, "global", tiny_maps, warm=False).problems
    exact = Planner(scene, "global", tiny_maps, warm=False).problems
    checked = 0
    for i in range(len(rough.steps)):
        fast = rough.threshold_options(i)
        full = exact.options(i)
        assert len(fast) == len(full)
        if rough.relaxed(i) < 1.0:  # no option keeps its threshold: the exact options are given
            assert fast is rough.options(i)
            continue
        assert not any(o.exact for o in fast if o.blocked is None and o.value.size)
        nx = rough.world.nav.shape[1]
        for f, e in zip(fast, full):
            assert _same(f) == _same(e)
            np.testing.assert_array_equal(f.candidate.poses, e.candidate.poses)
            thr = exact.option_threshold(e)
            assert np.array_equal(f.value >= thr, e.value >= thr)
            if not e.value.size:
                continue
            # every cell of the window, and cells off it (0 and -1 there)
            local = np.arange(e.value.size)
            flats = np.concatenate([e.window.to_global(local, nx), [0, rough.world.feasible.size - 1]])
            values, yaws = rough.exact_values([f, e], flats)
            expect_v = np.concatenate([e.value.ravel(), [0.0, 0.0]]).astype(np.float32)
            expect_k = np.concatenate([e.yaw_index.ravel(), [-1, -1]]).astype(np.int64)
            for v, k in zip(values, yaws):
                np.testing.assert_array_equal(v, expect_v)
                np.testing.assert_array_equal(k, expect_k)
            checked += int((e.value >= thr).sum())
    assert checked > 100


def test_a_plan_from_threshold_options_is_the_plan_from_exact_options(tiny_maps):
    """The default plans the same placements whether its steps' exact options were computed before
    (by another method on the same planner) or not; the published grasps' places (160 candidates) are
    planned from threshold-only options, the picks (20) from exact ones."""
    scene = SCENES[1]
    fresh = Planner(scene, "global", tiny_maps, warm=False)
    first = fresh.plan()
    kinds = {s.action: {o.exact for o in fresh.problems.threshold_options(s.index)} for s in fresh.problems.steps}
    assert kinds["pick"] == {True} and False in kinds["place"]
    primed = Planner(scene, "global", tiny_maps, warm=False)
    for i in range(len(primed.problems.steps)):
        primed.problems.options(i)  # every step's exact options, as `sequential` computes them
    second = primed.plan()
    assert [(s.status, s.arm, s.grasp, s.base) for s in first.steps] == [
        (s.status, s.arm, s.grasp, s.base) for s in second.steps
    ]
    assert any(s.status == "ok" for s in first.steps)


def test_exact_values_are_computed_once_per_cell_and_read_again(tiny_maps, monkeypatch):
    """``exact_values`` keeps what it computed per option: asked again for cells it has (in another
    order, mixed with new ones) it gives the same values and yaws, and runs the kernel on the new
    cells only."""
    problems = Planner(SCENES[1], "global", tiny_maps, warm=False).problems
    i = next(k for k, s in enumerate(problems.steps) if s.action == "place")
    opts = [o for o in problems.threshold_options(i) if not o.exact and o.blocked is None and o.value.size][:6]
    assert opts
    nx = problems.world.nav.shape[1]
    w = opts[0].window
    flats = w.to_global(np.arange(w.shape[0] * w.shape[1]), nx)
    first, half = flats[::2], flats[1::2]
    v1, k1 = problems.exact_values(opts, first)
    asked = []
    computed = cache.manipulation_maps

    def counting(rmap, trajectories, nav, yaws, cells, *args, **kwargs):
        asked.append(np.asarray(cells).copy())
        return computed(rmap, trajectories, nav, yaws, cells, *args, **kwargs)

    monkeypatch.setattr(cache, "manipulation_maps", counting)
    both = np.concatenate([half, first[::-1]])
    v2, k2 = problems.exact_values(opts, both)
    np.testing.assert_array_equal(v2[:, half.size :], v1[:, ::-1])
    np.testing.assert_array_equal(k2[:, half.size :], k1[:, ::-1])
    assert asked and not np.isin(np.concatenate(asked), first).any()  # only the new cells
    fresh = Planner(SCENES[1], "global", tiny_maps, warm=False).problems
    same = [o2 for o2 in fresh.threshold_options(i) if not o2.exact and o2.blocked is None and o2.value.size][:6]
    v3, k3 = fresh.exact_values(same, both)  # a planner that computes them all at once
    np.testing.assert_array_equal(v2, v3)
    np.testing.assert_array_equal(k2, k3)
