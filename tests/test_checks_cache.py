"""Verification answers kept across re-plans: a collision result's box, and what an update keeps."""

from __future__ import annotations

import numpy as np
import pytest
from support.planning import write_scene

from placement.collision import CollisionResult, SceneCollision
from placement.collision.scene import scene_shapes
from placement.planning import Planner
from placement.planning.updates import parse_update
from placement.planning.verification.ik import TrajectoryIK
from placement.planning.verification.verdicts import Checks
from placement.scene import load_scene


def _result(box):
    return CollisionResult(True, 0.1, None, None, box)


def test_kept_drops_the_changed_steps_and_the_touched_boxes():
    ik = TrajectoryIK(np.zeros((1, 7)))
    checks = Checks(
        {(0, None, 0, 5): ik, (1, None, 0, 5): ik, (2, 0.15, 1, 9): ik},
        {
            (0, None, 0, 5): _result((0.0, 0.0, 0.0, 1.0, 1.0, 1.0)),  # touches the change at x = 1
            (1, None, 0, 5): _result((2.0, 2.0, 0.0, 3.0, 3.0, 1.0)),  # far from it
            (1, None, 1, 6): _result(None),  # no box: cannot be kept
            (2, 0.15, 1, 9): _result((5.0, 5.0, 0.0, 6.0, 6.0, 1.0)),  # a changed step
        },
    )
    changed = [np.array([[1.0, 0.5, 0.2], [1.5, 0.6, 0.3]])]
    kept = checks.kept({2}, changed)
    assert set(kept.ik) == {(0, None, 0, 5), (1, None, 0, 5)}
    assert set(kept.collision) == {(1, None, 0, 5)}
    assert kept.ik[(0, None, 0, 5)] is ik
    assert set(checks.kept(set(), []).collision) == {(0, None, 0, 5), (1, None, 0, 5), (2, 0.15, 1, 9)}


@pytest.fixture(scope="module")
def scene_checker(tmp_path_factory, maps_dir, pr2):
    scene = load_scene(write_scene(tmp_path_factory.mktemp("box"), maps_dir))
    return scene, SceneCollision(pr2, scene)


def _with_crate(scene, centre, size):
    crate = {"name": "crate", "box": {"center": [float(v) for v in centre], "size": [float(v) for v in size]}}
    return parse_update({"obstacles": {"add": [crate]}}, scene).scene


@pytest.mark.parametrize("seed", range(8))
def test_a_piece_outside_the_box_leaves_the_result_as_it_was(scene_checker, pr2, seed):
    """A crate put anywhere outside a result's box does not change the result; the box is no
    bigger than it must be for a crate at its side to change it (the second half of the test)."""
    scene, checker = scene_checker
    rng = np.random.default_rng(seed)
    arm = sorted(pr2.arms)[seed % 2]
    a = pr2.arm(arm)
    # near home: mostly free configurations (random ones mostly collide with the robot itself)
    qs = np.clip(a.home + rng.normal(0.0, 0.3, size=(2, a.dof)), a.lower, a.upper)
    base = (float(rng.uniform(2.0, 2.3)), float(rng.uniform(1.4, 3.6)), float(rng.uniform(-np.pi, np.pi)))
    before = checker.check(arm, qs, base)
    assert before.box is not None
    lo, hi = np.array(before.box[:3]), np.array(before.box[3:])
    size = np.array([0.2, 0.2, 0.2])
    try:
        for axis in range(2):  # just beyond each face of the box (x and y: the crate stands on the floor)
            for side in (-1, 1):
                centre = (lo + hi) / 2
                centre[2] = 0.1
                centre[axis] = (hi[axis] + 0.1 + 1e-3) if side > 0 else (lo[axis] - 0.1 - 1e-3)
                checker.update(_with_crate(scene, centre, size))
                assert checker.check(arm, qs, base) == before
        # the same crate where the base stands: a free result changes
        checker.update(_with_crate(scene, [base[0], base[1], 0.1], size))
        after = checker.check(arm, qs, base)
        assert after != before or not before.free
    finally:
        checker.update(scene)


def test_an_update_keeps_the_checks_away_from_the_moved_object(tmp_path, maps_dir):
    planner = Planner(write_scene(tmp_path, maps_dir))
    assert planner.plan().ok
    old, before = planner.problems.checks, planner.scene
    # the box is picked and placed by steps 2 and 3; a 2 cm move
    planner.update({"objects": [{"name": "box", "position": [2.82, 2.4, 0.8]}]})
    kept = planner.problems.checks
    assert set(kept.ik) == {k for k in old.ik if k[0] not in (2, 3)}
    assert kept.ik and all(kept.ik[k] is old.ik[k] for k in kept.ik)
    # the box's pieces before and after the move: a result is kept when its box overlaps neither
    boxes = [s.aabb for sc in (before, planner.scene) for s in scene_shapes(sc) if s.name == "box"]
    assert len(boxes) == 2

    def apart(box):
        lo, hi = np.array(box[:3]), np.array(box[3:])
        return all(np.any(b[0] > hi) or np.any(b[1] < lo) for b in boxes)

    want = {k for k, r in old.collision.items() if k[0] not in (2, 3) and r.box is not None and apart(r.box)}
    assert set(kept.collision) == want
    # the place on the shelf is far from the table: its checks stand
    assert any(k[0] == 1 for k in kept.collision)
    assert planner.plan().ok
