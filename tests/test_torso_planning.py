"""The torso as a placement variable in the planner: options at every lift setting of the maps' record,
IK and the collision check with the lift at the option's value (checked here by pinocchio FK of the robot
with the lift moved), the lift the robot holds preferred, a high object reached only with the lift up."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from support.planning import SCENE, write_scene

import placement
from placement.maps.buildspec import TorsoSpec
from placement.planning.methods.ranking import Ranked
from placement.planning.planner import Planner
from placement.planning.problems.option import Option
from placement.planning.task_time import task_time
from placement.planning.torso import torso_first

LIFT = "torso_lift_joint"
SETTINGS = (0.0, 0.15, 0.31)


@pytest.fixture(scope="module")
def torso_maps(pr2, tmp_path_factory):
    """Small PR2 maps (both arms, 0.1 m cells) recording three lift settings."""
    built = {
        arm: placement.build_map(
            pr2,
            arm,
            samples=700_000,
            seed=1,
            resolution=0.1,
            bins=(10, 5, 10),
            progress=False,
            torso=TorsoSpec(LIFT, SETTINGS),
        )
        for arm in ("right", "left")
    }
    return placement.save_maps(tmp_path_factory.mktemp("torso_maps") / "pr2", pr2, built)


def _planar(x: float, y: float, yaw: float) -> np.ndarray:
    B = np.eye(4)
    B[:2, :2] = [[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]]
    B[:2, 3] = (x, y)
    return B


def _fk_at_step_torso(result, pr2) -> None:
    """Every step's TCP by pinocchio FK of the PR2 with the lift at that step's value."""
    for s in result.steps:
        assert s.ok, s.reason
        lift = s.joints[LIFT]
        assert lift in SETTINGS
        robot = pr2.with_fixed({LIFT: lift})
        q = np.array([s.joints[j] for j in robot.arm(s.arm).joints])
        T = _planar(*s.base) @ robot.tcp_pose(s.arm, q)
        target = np.asarray(s.tcp[-1])
        assert np.linalg.norm(T[:3, 3] - target[:3, 3]) < 0.01
        cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
        assert math.degrees(math.acos(cos)) < 3


@pytest.mark.slow
def test_every_step_has_options_at_every_setting(tmp_path, torso_maps):
    planner = Planner(write_scene(tmp_path, torso_maps))
    problems = planner.context.problems
    for i in range(len(problems.steps)):
        assert {o.torso for o in problems.options(i)} == set(SETTINGS)


def test_an_ordinary_table_keeps_the_lift_where_it_is(tmp_path, torso_maps, pr2):
    """The tables of the scene are 0.75 m high: the preset's 0.15 m serves every step, and the lift does
    not move (each method)."""
    for method in ("global", "sequential"):
        result = Planner(write_scene(tmp_path, torso_maps), method).plan()
        _fk_at_step_torso(result, pr2)
        assert [s.joints[LIFT] for s in result.steps] == [0.15] * len(result.steps), method
        assert result.verify(pr2) == []
        times = task_time(pr2, result, tuple(SCENE["robot"]["start"]))
        assert times is not None and all(t["torso_s"] == 0.0 for t in times["steps"])


@pytest.mark.parametrize("high", [False, True])
def test_the_certificate_from_regional_maps_equals_the_one_from_full_maps(tmp_path, torso_maps, maps_dir, high):
    """``global`` plans with the lift held and certifies over every setting: the settings it did not
    plan with get maps that only say where the threshold is kept (``region_options``). Its bound equals
    the one over the regions of the full maps of every setting (a fresh planner), and so does every
    step's region, group by group; the high cup relaxes no threshold, the 0.75 m tables hold the lift."""
    from placement.planning.program.forward import map_regions, travel_bound

    path = _high_scene(tmp_path, torso_maps) if high else write_scene(tmp_path, torso_maps)
    planner = Planner(path, "global")
    result = planner.plan()
    problems = planner.context.problems
    assert problems._regional, "some setting's regions came from regional maps"
    full = Planner(path, "global")
    ctx, start = full.context, full.start_cell()
    for i in range(len(problems.steps)):
        mine, theirs = map_regions(planner.context, i, regional=True), map_regions(ctx, i)
        assert mine.groups == theirs.groups and np.array_equal(mine.dense(), theirs.dense())
        assert theirs.any()
    assert result.certificate.lower_bound_s * full.robot.v_max == pytest.approx(travel_bound(ctx, start), rel=1e-12)


def _high_scene(tmp_path, maps_dir):
    """The cup on a 1.05 m high stand: no cell of the small test maps keeps the threshold for its top
    grasps with the lift at 0.15 m or 0 m, many do at 0.31 m."""
    scene = json.loads(json.dumps(SCENE))
    scene["obstacles"][0] = {"name": "stand", "box": {"center": [3.0, 2.5, 0.525], "size": [0.4, 0.4, 1.05]}}
    scene["obstacles"][0]["table"] = True
    scene["objects"] = [{"name": "cup", "position": [3.0, 2.5, 1.1], "yaw": 0.4, "size": [0.06, 0.06, 0.1]}]
    scene["task"] = [{"pick": "cup", "place": "spot"}]
    return write_scene(tmp_path, maps_dir, **{k: scene[k] for k in ("obstacles", "objects", "task")})


def test_a_high_object_raises_the_lift_and_the_place_lowers_it(tmp_path, torso_maps, maps_dir, pr2):
    held = Planner(_high_scene(tmp_path, maps_dir)).plan()  # maps without settings: the lift at 0.15 m
    assert not held.steps[0].ok
    result = Planner(_high_scene(tmp_path, torso_maps)).plan()
    _fk_at_step_torso(result, pr2)
    pick, place = result.steps
    assert pick.joints[LIFT] == 0.31
    assert place.joints[LIFT] == 0.15  # the shelf at 0.75 m: planned with the lift at the preset's value
    assert result.verify(pr2) == []
    times = task_time(pr2, result, tuple(SCENE["robot"]["start"]))
    assert times is not None
    first = times["steps"][0]
    assert first["torso_s"] == pytest.approx((pick.joints[LIFT] - 0.15) / 0.013)
    assert first["step_s"] >= first["torso_s"]


def _option(torso: float | None) -> Option:
    return Option("right", None, None, np.zeros((1, 1), np.float32), np.zeros((1, 1), np.int64), False, torso)  # type: ignore[arg-type]


def test_torso_first_orders_by_lift_motion():
    opts = [_option(0.31), _option(0.0), _option(0.15), _option(0.2)]
    assert torso_first(opts, [0, 1, 2, 3], 0.15) == [2, 3, 1, 0]  # 0 m is nearer 0.15 m than 0.31 m
    assert torso_first(opts, [3, 2, 1, 0], 0.0) == [1, 2, 3, 0]
    assert torso_first(opts, [0, 1, 2, 3], None) == [0, 1, 2, 3]


def test_ranking_adds_the_lift_time_as_travel(tmp_path, torso_maps):
    """Eq. 6 plus lambda_n x v_max x |lift change| / lift speed: 0.16 m at 0.013 m/s is 12.3 s, 6.15 m of
    travel at 0.5 m/s."""
    from placement.planning.methods.stepwise import torso_ranked

    ctx = Planner(write_scene(tmp_path, torso_maps), "sequential").context
    opts = [_option(0.15), _option(0.31)]
    ranked = [Ranked(1.0, 1, 0, 0.0), Ranked(2.0, 0, 0, 0.0)]
    out = torso_ranked(ctx, opts, ranked, 0.15, fixed=False)
    rate = ctx.config.lambda_n * ctx.robot.v_max
    moved = Ranked(1.0 + rate * 0.16 / 0.013, 1, 0, 0.0)
    assert moved.cost > 1.0
    assert out == sorted([Ranked(2.0, 0, 0, 0.0), moved])
    # fixed (and irm, lambda_n = 0): the placements at the lift's value first, each group in its order
    assert torso_ranked(ctx, opts, ranked, 0.15, fixed=True) == [ranked[1], ranked[0]]
    assert torso_ranked(ctx, opts, ranked, 0.31, fixed=True) == ranked
    assert torso_ranked(ctx, opts, ranked, None, fixed=False) == ranked


def test_an_update_reaches_the_lift_settings_collision_checks(tmp_path, torso_maps, pr2):
    """A crate added on a live planner is in the collision check of every lift setting used so far, and
    the re-planned task still holds (FK at each step's lift value, independent verify)."""
    from placement.planning.torso import collisions_at

    planner = Planner(_high_scene(tmp_path, torso_maps))
    planner.plan()
    ctx = planner.context
    raised = collisions_at(ctx, 0.31)
    assert raised is not None and raised is not ctx.collisions
    planner.update(
        {"obstacles": {"add": [{"name": "crate", "box": {"center": [4.5, 1.0, 0.3], "size": [0.4, 0.4, 0.6]}}]}}
    )
    assert collisions_at(planner.context, 0.31) is raised  # the same checker, updated
    assert "crate" in {s.name for s in raised.shapes}
    result = planner.plan()
    _fk_at_step_torso(result, pr2)
    assert result.steps[0].joints[LIFT] == 0.31
    assert result.verify(pr2) == []
