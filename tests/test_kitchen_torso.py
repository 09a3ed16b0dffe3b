"""tools/kitchen_torso.py, the map-free ground truth of which torso heights serve which steps: the two
kitchen scenes parse and their start poses leave room for the base; a shelf step and a low-table step
of each scene (PR2, TIAGo) are served at one end of the torso's range and not at the other; the reach
bound it prunes with never rejects a configuration forward kinematics reaches, and its kinematics equal
pinocchio's."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
TOOLS = ROOT / "tools"
sys.path.insert(0, str(TOOLS))

from kitchen_torso import Ground  # noqa: E402
from torso_reach import ReachBound, chain_fk, floor_ik  # noqa: E402

from placement.robots import load_robot  # noqa: E402
from placement.scene import load_scene  # noqa: E402

PR2_SCENE = ROOT / "examples" / "kitchen_torso.yaml"
TIAGO_SCENE = ROOT / "examples" / "kitchen_torso_tiago.yaml"


@pytest.mark.parametrize("path", [PR2_SCENE, TIAGO_SCENE], ids=lambda p: p.name)
def test_the_scenes_parse_with_a_high_shelf_and_a_low_table(path):
    scene = load_scene(path)
    tops = {o.name: o.shape.center[2] + o.shape.size[2] / 2 for o in scene.obstacles if o.table}
    assert 1.4 <= tops["high_shelf"] <= 1.6 and 0.3 <= tops["low_table"] <= 0.45
    assert scene.version == 2 and len(scene.task) == 3


@pytest.fixture(scope="module")
def pr2() -> Ground:
    return Ground(PR2_SCENE)


@pytest.fixture(scope="module")
def tiago() -> Ground:
    return Ground(TIAGO_SCENE)


def step_of(ground: Ground, action: str, target: str) -> int:
    return next(s.index for s in ground.steps if s.action == action and s.target == target)


# the sweeps (docs/bench/kitchen_torso.md) serve the shelf pick from 0.24 m (PR2) and 0.25 m (TIAGo),
# only with side grasps (they clear the board), and the low-table place up to 0.20 m
@pytest.mark.slow
@pytest.mark.parametrize(("which", "up"), [("pr2", 0.31), ("tiago", 0.30)])
def test_a_shelf_pick_needs_the_torso_up(which, up, request):
    ground = request.getfixturevalue(which)
    i = step_of(ground, "pick", "shelf_cup")
    found = ground.placement(i, up)
    assert found is not None and found.grasp is not None and found.grasp.startswith("side")
    assert ground.placement(i, 0.0) is None


# (scene, the lift's upper limit [m], the grasps tried at 0 (None: all))
@pytest.mark.slow
@pytest.mark.parametrize(("which", "top", "grasps"), [("pr2", 0.31, ["top"]), ("tiago", 0.35, None)])
def test_a_low_table_place_needs_the_torso_down(which, top, grasps, request):
    ground = request.getfixturevalue(which)
    i = step_of(ground, "place", "low_table_spot")
    assert ground.placement(i, 0.0, grasps) is not None
    assert ground.placement(i, top) is None


@pytest.mark.parametrize("which", ["pr2", "tiago"])
def test_the_start_pose_leaves_room_for_the_base(which, request):
    # the planner refuses a start whose footprint (plus its padding) touches an obstacle
    ground = request.getfixturevalue(which)
    x, y, yaw = ground.scene.start
    assert ground.world.pose_clear(x, y, yaw)
    assert ground.world.feasible[ground.world.nav.cell(x, y)]


@pytest.mark.parametrize("preset", ["pr2", "examples/robots/tiago.yaml"])
def test_the_reach_bound_admits_every_configuration_and_fk_is_pinocchios(preset):
    robot = load_robot(str(ROOT / preset) if preset.endswith(".yaml") else preset)
    rng = np.random.default_rng(1)
    for name in robot.arms:
        arm = robot.arm(name)
        bound = ReachBound.of(arm.chain, arm.lower, arm.upper, arm.continuous)
        q = rng.uniform(arm.lower, arm.upper, (500, arm.dof))
        _, tcp = chain_fk(arm.chain, q)
        for k in range(5):
            np.testing.assert_allclose(tcp[k], robot.tcp_pose(name, q[k]), atol=1e-9)
        # the base at a random pose: the TCP in the world, the bound asked about that base
        base = np.array([[0.7, -1.2, 2.1]])
        c, s = np.cos(base[0, 2]), np.sin(base[0, 2])
        B = np.array([[c, -s, 0, 0.7], [s, c, 0, -1.2], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        assert all(bound.admits((B @ tcp[k])[None], base)[0] for k in range(len(q)))
        # a pose 0.3 m beyond the bound's reach straight ahead is rejected
        far = np.eye(4)
        far[:3, 3] = bound.centre + [bound.length + np.linalg.norm(bound.radial) + 1.0, 0, 0]
        assert not bound.admits(far[None], np.zeros((1, 3)))[0]
        # the reduced IK finds a configuration at a reachable pose's height and tilt
        sols = floor_ik(arm.chain, arm.lower, arm.upper, arm.continuous, tcp[0], q[:16])
        assert len(sols) > 0
