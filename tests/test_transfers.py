"""Transfers: the arm and grasp that pick an object place it, the object is set down as it was held
(upright as picked, resting on its support), and the object in the hand is collision-checked."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from oracle_collision import IndependentCheck
from support.budgets import unbudgeted

from placement.collision import SceneCollision
from placement.planning import Planner
from placement.planning.problems.steps import object_grasps, step_candidates, task_steps
from placement.planning.problems.transfer import (
    Held,
    held_object,
    place_orientations,
    placed_pose,
    support_surface,
    tilt_between,
    transfer_places,
)
from placement.planning.settings import PlannerConfig
from placement.scene import SceneError, load_scene, parse_scene
from placement.scene.poses import quaternion_matrix, yaw_quaternion

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
METHODS = ("sequential", "single-step", "irm", "fixed", "optimal")


def assert_transfers(result) -> int:
    """Every place by its pick's arm and grasp, the object turned about z only; returns the count."""
    steps = [s for s in result.steps if s.ok]
    n = 0
    for k, s in enumerate(steps):
        if s.action != "place":
            continue
        pick = [p for p in steps[:k] if p.action == "pick" and p.target == s.object][-1]
        assert (s.arm, s.grasp) == (pick.arm, pick.grasp), (s.step, s.arm, s.grasp, pick.arm, pick.grasp)
        R = np.asarray(s.tcp)[-1][:3, :3] @ np.asarray(pick.tcp)[-1][:3, :3].T
        assert R[2, 2] > math.cos(math.radians(6)), (s.step, math.degrees(math.acos(min(1.0, R[2, 2]))))
        n += 1
    return n


# -- the object's place poses -----------------------------------------------------------------------


def scene_doc(**extra) -> dict:
    doc = {
        "version": 2,
        "resolution": 0.05,
        "bounds": [0, 0, 4, 4],
        "robot": {"preset": "pr2", "start": [0.6, 0.6, 0]},
        "obstacles": [
            {"name": "table", "table": True, "box": {"center": [2, 2, 0.375], "size": [0.8, 0.6, 0.75]}},
            {"name": "side", "table": True, "box": {"center": [3.2, 1, 0.25], "size": [0.5, 0.5, 0.5]}},
        ],
        "objects": [
            {"name": "cup", "position": [1.9, 2.1, 0.8], "yaw": 0.3, "size": [0.06, 0.06, 0.10]},
            {
                "name": "can",
                "position": [2.2, 1.9, 0.785],
                "orientation": [0.7071068, 0, 0, 0.7071068],
                "size": [0.07, 0.07, 0.12],
            },
        ],
        "place_locations": [{"name": "spot", "position": [3.2, 1.0, 0.6]}],
        "task": [{"pick": "cup", "place": "spot"}, {"pick": "can", "place": "spot"}],
    }
    doc.update(extra)
    return doc


def test_objects_rest_on_the_support_under_the_place_upright_as_picked():
    scene = parse_scene(scene_doc())
    loc = scene.place_location("spot")
    assert support_surface(scene, 3.2, 1.0, 0.6) == (0.5, "side")
    assert support_surface(scene, 3.2, 1.0, 0.5) == (0.5, "side")  # z on the top itself
    assert support_surface(scene, 3.2, 1.0, 0.8) == (0.8, None)  # more than 0.25 m above: none
    assert support_surface(scene, 3.6, 1.0, 0.6) == (0.6, None)  # beside the table
    for obj in scene.objects:
        R0 = quaternion_matrix(obj.orientation)
        turns = place_orientations(obj, loc, 8)
        assert len(turns) == 8
        for _label, R in turns:
            assert tilt_between(R, R0) < 1e-6
            T, support = placed_pose(scene, obj, loc, R)
            assert support == "side"
            bottom = T[2, 3] - np.abs(T[2, :3]) @ np.asarray(obj.size) / 2
            assert bottom == pytest.approx(0.5, abs=1e-12)
            np.testing.assert_allclose(T[:2, 3], [3.2, 1.0], atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_a_place_holds_the_object_as_the_grasp_did(seed):
    """The TCP-to-object transform at the place equals the one at the pick, for every pose of a
    user grasp of random poses on an object of random orientation: the object is rigid in the hand."""
    rng = np.random.default_rng(seed)

    def unit(v):
        return [float(x) for x in v / np.linalg.norm(v)]

    poses = [[*(float(x) for x in rng.uniform(-0.05, 0.05, 3)), *unit(rng.normal(size=4))] for _ in range(3)]
    doc = scene_doc(
        objects=[
            {
                "name": "cup",
                "position": [1.9, 2.1, 0.9],
                "orientation": unit(rng.normal(size=4)),
                "size": [0.05, 0.06, 0.07],
                "grasps": [{"name": "g", "poses": poses}],
            }
        ],
        task=[{"pick": "cup", "place": "spot"}],
    )
    scene = parse_scene(doc)
    obj = scene.object("cup")
    grasps = object_grasps(obj, 2)
    places = transfer_places(scene, obj, scene.place_location("spot"), grasps, 8)
    assert len(places) == 8
    for c in places:
        assert c.grasp == "g" and c.support == "side"
        assert tilt_between(c.object_pose[:3, :3], obj.pose[:3, :3]) < 1e-6
        for P, G in zip(c.poses, grasps[0].poses):
            np.testing.assert_allclose(np.linalg.inv(P) @ c.object_pose, np.linalg.inv(G) @ obj.pose, atol=1e-8)
        held = held_object(obj, c)
        np.testing.assert_allclose(c.poses[-1] @ held.tcp_to_object, c.object_pose, atol=1e-12)


def test_v1_places_keep_their_tcp_targets_for_objects_as_tall_as_the_gap():
    """Version 1 place positions are TCP targets 0.1 m above a table: a 0.1 m tall object held from
    the top puts the TCP exactly there, as before transfers."""
    scene = load_scene(EXAMPLES / "table_clearing.yaml")
    steps = task_steps(scene)
    cfg = PlannerConfig()
    places = step_candidates(scene, steps[1], cfg)  # cup_1 (0.10 m tall) at place_a (0.85 m)
    assert {c.grasp for c in places} == {"top", "top-flipped"}
    for c in places:
        np.testing.assert_allclose(c.poses[-1][:3, 3], [1.6, 1.6, 0.85], atol=1e-12)
        np.testing.assert_allclose(c.poses[0][:3, 3], [1.6, 1.6, 0.95], atol=1e-12)
        assert c.support == "place_table_a"
    # the turns of the place share their TCP positions bit for bit (one IRM pass), and a top grasp's
    # turn by a half turn is the other top grasp's: 8 distinct trajectories for 16 candidates
    assert len({c.poses[:, :3, 3].tobytes() for c in places}) == 1
    assert len(places) == 16 and len({c.poses.tobytes() for c in places}) == 8


def test_place_orientations_that_turn_the_object_over_are_refused():
    doc = scene_doc(task=[{"pick": "cup", "place": "spot"}])
    # top-down TCP quaternions: the meaning place orientations had before transfers
    doc["place_locations"][0]["orientations"] = [[0.0, 0.0, 0.0, 1.0], [0.7071068, 0.7071068, 0.0, 0.0]]
    with pytest.raises(
        SceneError,
        match=r"place_locations\[0\]\.orientations\[1\]: would set object 'cup' "
        r"down tilted 180 deg",
    ):
        parse_scene(doc)
    doc["place_locations"][0]["orientations"] = [[0.0, 0.0, 0.7071068, 0.7071068]]
    scene = parse_scene(doc)
    ((label, R),) = place_orientations(scene.object("cup"), scene.place_location("spot"), 8)
    np.testing.assert_allclose(R, quaternion_matrix(yaw_quaternion(math.pi / 2)), atol=1e-7)
    # the lying can keeps lying: its picked orientation turned about z is allowed
    doc = scene_doc(task=[{"pick": "can", "place": "spot"}])
    doc["place_locations"][0]["orientations"] = [[0.5, 0.5, 0.5, 0.5]]
    assert parse_scene(doc).place_location("spot").orientations is not None
    doc["place_locations"][0]["orientations"] = [[0.0, 0.0, 0.0, 1.0]]  # standing up: a turn the hand can't do
    with pytest.raises(SceneError, match="tilted 90 deg"):
        parse_scene(doc)


# -- plans --------------------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", ["table_clearing.yaml", "table_clearing_obstacles.yaml"])
def test_every_method_keeps_arm_and_grasp_and_sets_objects_upright(maps_dir, pr2, name):
    scene = unbudgeted(load_scene(EXAMPLES / name))
    planner = Planner(scene, maps=maps_dir)
    for method in METHODS:
        planner.set_method(method)
        result = planner.plan()
        if method == "fixed" and not result.ok:  # a baseline: crates may block every fixed placement
            assert "fixed placements" in result.failed_step.reason
        else:
            assert result.ok, (method, [s.reason for s in result.steps if not s.ok])
        assert assert_transfers(result) == sum(s.action == "place" for s in result.steps if s.ok)
        assert result.verify(pr2) == []
        doc = result.to_json()
        for s in doc["steps"]:
            if s["action"] == "place":
                assert s["object"] and len(s["placed_pose"]) == 7 and s["support"].startswith("place_table")
                assert s["trajectory"].startswith(s["grasp"] + "@yaw")


@pytest.mark.slow
def test_generated_scenes_keep_transfers_with_every_method(maps_dir, pr2, tmp_path):
    from placement.evaluation.generate import generate_scene

    for k, obstacles in ((0, False), (1, True)):
        doc = generate_scene(11 + k, k, obstacles=obstacles, objects=4)
        scene = unbudgeted(parse_scene(doc, name=f"gen{k}"))
        planner = Planner(scene, maps=maps_dir)
        for method in METHODS:
            planner.set_method(method)
            result = planner.plan()
            assert assert_transfers(result) == sum(s.action == "place" for s in result.steps if s.ok)
            assert result.verify(pr2) == []


SHELF = {
    "version": 2,
    "resolution": 0.05,
    "bounds": [0, 0, 5, 4],
    "robot": {"preset": "pr2", "start": [1.0, 2.0, 0.0]},
    "obstacles": [
        {"name": "table", "table": True, "box": {"center": [2.5, 0.8, 0.375], "size": [0.6, 0.6, 0.75]}},
        # a shelf compartment open to the west: bottom board at 0.80 m, ceiling board GAP above it
        {"name": "shelf", "table": True, "box": {"center": [4.2, 2.0, 0.40], "size": [0.4, 0.8, 0.80]}},
        {"name": "ceiling", "box": {"center": [4.2, 2.0, 1.5], "size": [0.4, 0.8, 0.02]}},
        {"name": "back", "box": {"center": [4.45, 2.0, 1.0], "size": [0.1, 0.8, 2.0]}},
    ],
    "objects": [{"name": "bottle", "position": [2.4, 0.85, 0.85], "yaw": 0.0, "size": [0.06, 0.06, 0.20]}],
    "place_locations": [{"name": "in_shelf", "position": [4.15, 2.0, 0.80]}],
    "task": [{"pick": "bottle", "place": "in_shelf"}],
}


def shelf_scene(gap: float):
    doc = yaml.safe_load(yaml.safe_dump(SHELF))
    doc["obstacles"][2]["box"]["center"][2] = 0.80 + gap + 0.01
    doc["obstacles"][3]["box"]["size"][2] = 2 * (0.80 + gap + 0.02)
    doc["obstacles"][3]["box"]["center"][2] = 0.80 + gap + 0.02
    return unbudgeted(parse_scene(doc, name=f"shelf{gap}"))


@pytest.mark.slow
def test_a_bottle_goes_into_a_low_shelf_upright_through_the_gap(maps_dir, pr2):
    """Between the boards 0.26 m apart a top grasp (its pre-place 0.1 m above the bottle's top) cannot
    set the 0.2 m bottle down; a side grasp slides it in upright, clear of both boards, and the
    independent check finds the carried bottle clear of everything but its support."""
    scene = shelf_scene(0.26)
    planner = Planner(scene, maps=maps_dir)
    result = planner.plan()
    assert result.ok, [s.reason for s in result.steps if not s.ok]
    pick, place = result.steps
    assert pick.grasp.startswith("side-") and assert_transfers(result) == 1
    assert place.support == "shelf"
    assert result.verify(pr2) == []
    checks = IndependentCheck(pr2, scene).check_plan(result.to_json())
    assert all(c.free for c in checks), [(c.scene_hits, c.self_hits, c.object_hits) for c in checks]
    # a top grasp's pre-place holds the TCP 0.1 m above the bottle's top: inside the ceiling board
    tops = [o for o in planner.problems.options(1) if o.candidate.grasp.startswith("top")]
    assert tops and all(o.candidate.poses[0][2, 3] > 0.80 + 0.26 for o in tops)
    # a gap lower than the bottle: no place fits; the last pick verified is kept and the place says which
    # place failed for which arm (as the whole-task methods name the place, not its pick).
    # Each side grasp's place search ends at its cap, the held bottle against the ceiling board wherever
    # the arm reaches: 300 tries per arm and grasp show that as the default 2000 did (8 s, not 42 s)
    low_scene = shelf_scene(0.18)
    low_scene = replace(low_scene, planner={**low_scene.planner, "ik_cap": 300})
    low = Planner(low_scene, "sequential", maps=maps_dir).plan()  # the stepwise pick explains
    assert not low.ok and [s.action for s in low.steps] == ["pick", "place"] and low.steps[0].ok
    assert "set it down at 'in_shelf'" in low.steps[-1].reason
    assert "bottle (held) vs ceiling" in low.steps[-1].reason


def test_the_carried_object_is_checked_against_the_scene_and_may_rest_on_its_support(pr2):
    scene = parse_scene(SHELF)
    checker = SceneCollision(pr2, scene, padding=0.005)
    obj = scene.object("bottle")
    q = pr2.arm("right").home[None]
    tcp = pr2.tcp_pose("right", q[0])
    base = (3.0, 2.0, 0.0)
    B = np.eye(4)
    B[:2, 3] = base[:2]

    def held_at(z_bottom: float, x: float = 4.15):
        """The bottle held by the home TCP, placed so that its box is at (x, 2.0) with its bottom at z."""
        T_obj = np.eye(4)
        T_obj[:3, 3] = (x, 2.0, z_bottom + 0.10)
        return Held("bottle", np.asarray(obj.size), np.linalg.inv(B @ tcp) @ T_obj, "shelf")

    gone = ["bottle"]
    assert checker.check("right", q, base, gone=gone, held=held_at(0.80)).free  # resting on the board
    assert checker.check("right", q, base, gone=gone, held=held_at(0.795)).free  # 5 mm in: within the tolerance
    sunk = checker.check("right", q, base, gone=gone, held=held_at(0.78))  # 2 cm into the board
    assert not sunk.free and sunk.culprit == "bottle (held) vs shelf"
    hit = checker.check("right", q, base, gone=gone, held=held_at(1.30))  # through the ceiling board
    assert not hit.free and hit.culprit == "bottle (held) vs ceiling"
    wall = checker.check("right", q, base, gone=gone, held=held_at(0.80, x=4.40))  # into the back wall
    assert not wall.free and wall.culprit == "bottle (held) vs back"
    # without the held object the same arm configuration is free: the object made the difference
    assert checker.check("right", q, base, gone=gone).free


CORRIDOR = """
version: 1
resolution: 0.05
bounds: [0.0, 0.0, 5.0, 5.0]
robot: {preset: PRESET, start: [3.5, 1.0, 0.0]}
obstacles:
  # a corridor 0.8 m wide between two low cabinet blocks, running north from the room to a table
  - {name: block_w, box: {center: [1.3, 3.6, 0.25], size: [1.6, 2.8, 0.5]}}
  - {name: block_e, box: {center: [3.7, 3.6, 0.25], size: [1.6, 2.8, 0.5]}}
  - {name: table, box: {center: [2.5, 4.75, 0.375], size: [0.8, 0.5, 0.75]}, table: true}
  - {name: pick_table, box: {center: [1.0, 1.0, 0.375], size: [0.6, 0.6, 0.75]}, table: true}
objects:
  - {name: cup, position: [1.0, 1.0, 0.80], yaw: 0.0, size: [0.06, 0.06, 0.10]}
place_locations:
  - {name: corner, position: [2.85, 4.6, 0.85]}
task:
  - {pick: cup, place: corner}
"""


def test_a_place_only_one_arm_reaches_decides_the_arm_of_the_pick(maps_dir, tmp_path):
    """A PR2 towing a cart (1.235 m long) fits the 0.8 m corridor facing north only; the place in
    the table's north-east corner is then 0.35 m right of the base: the right arm reaches it, the
    left does not. The pick on its own would take the left arm; the transfer takes the right."""
    from placement.planning.methods.stepwise import Holding, plan_step
    from placement.robots.preset import PRESET_DIR

    preset = yaml.safe_load((PRESET_DIR / "pr2.yaml").read_text())
    preset["footprint"] = [[0.335, 0.335], [-0.9, 0.335], [-0.9, -0.335], [0.335, -0.335]]
    (tmp_path / "pr2_cart.yaml").write_text(yaml.safe_dump(preset))
    (tmp_path / "corridor.yaml").write_text(CORRIDOR.replace("PRESET", str(tmp_path / "pr2_cart.yaml")))
    planner = Planner(unbudgeted(load_scene(tmp_path / "corridor.yaml")), "sequential", maps=maps_dir)
    pick, place = planner.problems.steps
    ctx, method = planner.context, planner.method
    start = Holding.start(ctx, planner.start_cell())
    alone, _ = plan_step(ctx, method, pick, start, False)
    assert alone.ok and alone.arm == "left"
    left, _ = plan_step(ctx, method, place, start, False, {("left", "top"), ("left", "top-flipped")})
    assert not left.ok
    result = planner.plan()
    assert result.ok, [s.reason for s in result.steps if not s.ok]
    assert [s.arm for s in result.steps] == ["right", "right"] and assert_transfers(result) == 1
    assert abs(result.steps[1].base[2] - math.pi / 2) < 0.1  # facing north, in the corridor


def test_evaluation_counts_transfer_faults(maps_dir, pr2):
    """The check `placement evaluate` runs on every plan: a place with another arm or grasp than its
    pick, or tilted, is counted (here made so by hand)."""
    from placement.evaluation.evaluate import transfer_faults

    scene = unbudgeted(load_scene(EXAMPLES / "table_clearing.yaml"))
    result = Planner(scene, maps=maps_dir).plan()
    assert result.ok and transfer_faults(result) == 0
    place = result.steps[1]

    def with_place(**changes):
        """The plan with its place step changed."""
        steps = list(result.steps)
        steps[1] = replace(place, **changes)
        return replace(result, steps=steps)

    other_grasp = "top" if place.grasp == "top-flipped" else "top-flipped"
    assert transfer_faults(with_place(grasp=other_grasp)) == 1
    other_arm = "left" if place.arm == "right" else "right"
    assert transfer_faults(with_place(grasp=other_grasp, arm=other_arm)) == 1  # one problem line for both
    tilted = np.array(place.tcp)
    tilted[-1][:3, :3] = tilted[-1][:3, :3] @ quaternion_matrix([math.sin(0.1), 0.0, 0.0, math.cos(0.1)])
    assert transfer_faults(with_place(tcp=tilted)) == 1
    assert any("set down tilted 11.5 deg" in p for p in with_place(tcp=tilted).verify(pr2))


def test_the_viewer_refuses_a_plan_whose_place_changes_the_grasp(maps_dir, tmp_path):
    """`placement view --plan`: a plan whose place holds the object by another grasp than its pick
    is not a plan of this scene's robot executing it: one line naming the step."""
    import json

    from placement.viewer.plan_file import PlanFileError, load_checked_plan

    scene = unbudgeted(load_scene(EXAMPLES / "table_clearing.yaml"))
    doc = Planner(scene, maps=maps_dir).plan().to_json()
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    assert len(load_checked_plan(path, scene)) == 6
    doc["steps"][1]["grasp"] = "top" if doc["steps"][1]["grasp"] == "top-flipped" else "top-flipped"
    path.write_text(json.dumps(doc))
    with pytest.raises(PlanFileError, match=r"steps\[1\]: placed by arm \w+ with grasp top(-flipped)?, picked by"):
        load_checked_plan(path, scene)


BOARD_AND_BIN = """
version: 2
resolution: 0.05
bounds: [0, 0, 5, 4]
robot: {preset: pr2, start: [2.5, 0.8, 0.0]}
obstacles:
  - {name: pick_table, table: true, box: {center: [1.5, 2.0, 0.375], size: [0.6, 0.6, 0.75]}}
  # a board over the cup: a hand from above meets it
  - {name: board, box: {center: [1.5, 2.0, 0.99], size: [0.6, 0.6, 0.04]}}
  - {name: place_table, table: true, box: {center: [3.5, 2.0, 0.375], size: [0.6, 0.6, 0.75]}}
  # a bin on the place table, its walls 0.06 .. 0.16 m from the place: only a hand from above fits
  - {name: wall_e, box: {center: [3.61, 2.0, 0.85], size: [0.10, 0.32, 0.20]}}
  - {name: wall_w, box: {center: [3.39, 2.0, 0.85], size: [0.10, 0.32, 0.20]}}
  - {name: wall_n, box: {center: [3.5, 2.11, 0.85], size: [0.12, 0.10, 0.20]}}
  - {name: wall_s, box: {center: [3.5, 1.89, 0.85], size: [0.12, 0.10, 0.20]}}
objects:
  - name: cup
    position: [1.5, 2.0, 0.85]
    yaw: 0.0
    size: [0.06, 0.06, 0.20]
    grasps:
      - name: top
        poses: [[0.0, 0.0, 0.16, 0.70710678, 0.70710678, 0.0, 0.0], [0.0, 0.0, 0.06, 0.70710678, 0.70710678, 0.0, 0.0]]
      - name: side
        poses:
          - [0.13, 0.0, 0.0, 0.704415463, -0.061634853, -0.704415463, 0.061634853]
          - [0.03, 0.0, 0.0, 0.704415463, -0.061634853, -0.704415463, 0.061634853]
place_locations:
  - {name: bin, position: [3.5, 2.0, 0.85]}
task:
  - {pick: cup, place: bin}
"""


@pytest.mark.parametrize("method", ["global", "optimal", "sequential", "single-step"])
def test_a_place_no_grasp_of_the_pick_fits_names_the_transfer_at_the_place(maps_dir, tmp_path, method):
    """The board lets only a side grasp pick the cup; the bin's walls let only a top grasp set it
    down. Every method keeps the verified pick and names the place: no grasp that picks it sets it
    down there, because the gripper meets the bin's walls at every place pose (the step-by-step
    methods said the pick's gripper hit the board; the whole-task ones gave no reason per grasp)."""
    (tmp_path / "bin.yaml").write_text(BOARD_AND_BIN)
    planner = Planner(tmp_path / "bin.yaml", method, maps_dir)
    result = planner.plan()
    pick, place = result.steps
    assert pick.ok and pick.grasp == "side", getattr(pick, "reason", "")
    assert result.verify(planner.robot, scene=planner.scene) == []
    assert not place.ok and place.step == 1
    assert place.reason.startswith("no grasp of 'cup' lets the arm that picks it set it down at 'bin'")
    assert "grasp side: the gripper collides at every place pose" in place.reason and " vs wall_" in place.reason
    transfers = place.diagnosis["transfers"]
    assert {t["grasp"] for t in transfers} == {"side"} and all("vs wall_" in t["failed"] for t in transfers)
