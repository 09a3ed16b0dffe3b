"""The collision check's spatial prefilter (scene pieces on a coarse grid, built once per scene):
the same results as looking at every piece, on random cluttered scenes; a check's work depends on the
pieces near the robot only (10,000 far boxes)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np
import pytest
from support.collision import scene_doc, with_occupancy
from support.robots import random_configs

from placement.collision import SceneCollision
from placement.collision.checker import GRID_PIECES, model_aabb
from placement.collision.scene import PieceGrid
from placement.planning import parse_scene
from placement.scene import Box, Cylinder, Obstacle, Polygon

TABLE_X = 1.0


def clutter(rng, n: int, lo=(-8.0, -8.0), hi=(8.0, 8.0), sizes=(0.01, 0.4), keep_out=None) -> list[Obstacle]:
    """``n`` random obstacles (boxes turned by any yaw, some cylinders and triangles) in the window
    ``lo`` .. ``hi`` [m], none inside ``keep_out`` ((xmin, ymin, xmax, ymax): the table's objects)."""
    out = []
    while len(out) < n:
        x, y = rng.uniform(lo, hi)
        if (
            keep_out is not None
            and keep_out[0] - 0.7 < x < keep_out[2] + 0.7
            and keep_out[1] - 0.7 < y < keep_out[3] + 0.7
        ):
            continue
        s = rng.uniform(*sizes, 3)
        kind = rng.integers(10)
        name = f"clutter_{len(out)}"
        if kind < 7:
            shape = Box(np.array([x, y, rng.uniform(0, 1.6)]), s, float(rng.uniform(-np.pi, np.pi)))
        elif kind < 9:
            shape = Cylinder(np.array([x, y, s[2] / 2]), float(s[0] / 2), float(s[2]))
        else:
            angles = np.sort(rng.uniform(0, 2 * np.pi, 3))
            shape = Polygon(np.column_stack([x + s[0] * np.cos(angles), y + s[1] * np.sin(angles)]))
        out.append(Obstacle(name, shape))
    return out


def cluttered(rng, n: int, occupancy: bool):
    scene = parse_scene(scene_doc("pr2", TABLE_X))
    scene = dataclasses.replace(
        scene, obstacles=scene.obstacles + tuple(clutter(rng, n, keep_out=(TABLE_X - 0.4, -0.5, TABLE_X + 0.4, 0.5)))
    )
    return with_occupancy(scene) if occupancy else scene


def checkers(pr2, scene, padding):
    fast = SceneCollision(pr2, scene, padding=padding)
    slow = SceneCollision(pr2, scene, padding=padding)
    slow.prefilter = False
    slow.update(scene)
    assert fast._grid is not None and slow._grid is None
    return fast, slow


@pytest.mark.parametrize(
    "seed, n, occupancy, padding", [(1, 150, False, 0.0), (2, 400, True, 0.02), (4, 600, False, 0.05)]
)
def test_prefiltered_checks_equal_checks_of_every_piece(pr2, seed, n, occupancy, padding):
    """Random bases among the clutter (and beside the table), random arm trajectories, the gripper's
    object and objects carried away: every result (verdict, clearance, culprit, pose) equal bit for bit;
    and the grid leaves pieces out (else the test would prove nothing)."""
    rng = np.random.default_rng(seed)
    scene = cluttered(rng, n, occupancy)
    fast, slow = checkers(pr2, scene, padding)
    left_out = seen = 0
    verdicts = set()
    for k in range(40):
        arm = ("right", "left")[k % 2]
        a = pr2.arm(arm)
        q = random_configs(a, 1, rng)[0]
        qs = np.array([q, np.clip(q + rng.normal(0, 0.2, a.dof), a.lower, a.upper)])
        if k % 3:
            base = (*rng.uniform(-7.5, 7.5, 2), rng.uniform(-np.pi, np.pi))
        else:
            base = (TABLE_X - 0.3 - rng.uniform(0.3, 0.6), rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4))
        grasped = (None, "cup_1", "box_2")[k % 3]
        gone = ("box_2",) if k % 5 == 0 and grasped != "box_2" else ()
        want = slow.check(arm, qs, base, grasped=grasped, gone=gone)
        got = fast.check(arm, qs, base, grasped=grasped, gone=gone)
        assert got == want, (k, base, got, want)
        verdicts.add((want.free, bool(want.culprit) and " vs clutter_" in want.culprit))
        A = fast.geometry.base_in_model @ np.linalg.inv(_base(base))
        inst = fast._instances(arm, qs, fast.geometry.arm_shapes(arm))
        seen += len(fast._scene_in_model(A, inst)["shapes"])
        left_out += len(slow._scene_in_model(A, inst)["shapes"]) - len(fast._scene_in_model(A, inst)["shapes"])
    assert left_out > 10 * seen  # the grid did its work
    assert (False, True) in verdicts and (True, False) in verdicts, verdicts  # hits on the clutter, free ones


def _base(base):
    from placement.collision.checker import base_matrix

    return base_matrix(*base)


@pytest.mark.slow
def test_prefiltered_pairs_equal_the_brute_force_pair_list(pr2):
    """The candidate pairs themselves (robot instance, scene piece, lower bound) are the same, with
    dense small clutter (every piece near the edge of the robot's window counts)."""
    rng = np.random.default_rng(7)
    scene = parse_scene(scene_doc("pr2", TABLE_X))
    scene = with_occupancy(
        dataclasses.replace(
            scene,
            obstacles=scene.obstacles
            + tuple(clutter(rng, 3000, sizes=(0.01, 0.1), keep_out=(TABLE_X - 0.4, -0.5, TABLE_X + 0.4, 0.5))),
        )
    )
    fast, slow = checkers(pr2, scene, 0.01)
    near_edge = 0
    for k in range(40):
        arm = ("right", "left")[k % 2]
        q = random_configs(pr2.arm(arm), 2, rng)
        base = (*rng.uniform(-7.5, 7.5, 2), rng.uniform(-np.pi, np.pi))
        A = fast.geometry.base_in_model @ np.linalg.inv(_base(base))
        arm_shapes = fast.geometry.arm_shapes(arm)
        pairs = []
        for c in (fast, slow):
            inst = c._instances(arm, q, arm_shapes)
            sc = c._scene_in_model(A, inst)
            p = c._pairs(inst, sc, arm_shapes, "cup_1", frozenset({"box_2"}))
            names = [s.name if hasattr(s, "name") else f"occupancy{s}" for s in sc["shapes"]]
            pairs.append(
                sorted(
                    (int(a), names[int(b)] if not s else f"self{int(b)}", float(lb))
                    for a, b, s, lb in zip(p["a"], p["b"], p["self"], p["lb"])
                )
            )
        assert pairs[0] == pairs[1], k
        near_edge += sum(lb > fast.cap - 0.05 for _, name, lb in pairs[1] if name.startswith("clutter"))
    assert near_edge > 50  # many pairs close to the cap: a prefilter that cut short would show


def test_grid_near_is_every_overlapping_piece():
    """PieceGrid.near against a plain overlap test of the reach squares, for tiny, large and huge
    pieces and windows inside, across and outside the grid."""
    rng = np.random.default_rng(3)
    c = rng.uniform(-20, 20, (3000, 3))
    half = rng.choice([0.005, 0.2, 3.0, 40.0], size=(3000, 1), p=[0.6, 0.3, 0.09, 0.01]) * rng.uniform(
        0.2, 1, (3000, 3)
    )
    aabb = np.stack([c - half, c + half], axis=1)
    for tilt in (0.0, None):
        grid = PieceGrid(aabb, tilt)
        assert len(grid.wide) > 0
        for _ in range(300):
            lo = rng.uniform(-30, 30, 2)
            hi = lo + rng.uniform(0, 8, 2)
            want = np.flatnonzero(np.all(grid.lo <= hi, axis=1) & np.all(grid.hi >= lo, axis=1))
            np.testing.assert_array_equal(grid.near(lo, hi), want)
        assert len(grid.near([100, 100], [101, 101])) == 0
    assert len(PieceGrid(np.zeros((0, 2, 3))).near([0, 0], [1, 1])) == 0


def _rotation(rng, upright: bool) -> np.ndarray:
    if upright:
        a = rng.uniform(-np.pi, np.pi)
        return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def test_reach_squares_hold_the_checks_bound():
    """The reason near() loses nothing: the model-frame AABB of a piece's AABB (what _pairs measures
    to), for any turn about z (tilt 0) or any rotation (tilt None), stays within the reach square's
    radius of the piece's centre."""
    rng = np.random.default_rng(5)
    c = rng.uniform(-5, 5, (500, 3))
    half = rng.uniform(0.001, 2.0, (500, 3)) * rng.choice([0.01, 1.0, 5.0], (500, 1))
    aabb = np.stack([c - half, c + half], axis=1)
    for tilt, upright in ((0.0, True), (None, False), (None, True)):
        grid = PieceGrid(aabb, tilt)
        radius = (grid.hi[:, 0] - grid.lo[:, 0]) / 2
        for _ in range(50):
            A = np.eye(4)
            A[:3, :3], A[:3, 3] = _rotation(rng, upright), rng.uniform(-3, 3, 3)
            box = model_aabb(aabb, A)
            e = (box[:, 1] - box[:, 0]) / 2
            reach = np.linalg.norm(e[:, :2] if tilt is not None else e, axis=1)
            assert np.all(reach <= radius), np.max(reach - radius)
    assert PieceGrid(aabb, 0.0).hi[0, 0] - c[0, 0] < PieceGrid(aabb, None).hi[0, 0] - c[0, 0]


@pytest.mark.slow
def test_far_clutter_costs_nothing_per_check(pr2):
    """10,000 one-centimetre boxes 4 m and more from the robot: each check looks at the pieces of the
    clutter-free scene only, and takes about the time it takes there (today's brute force: ~20x)."""
    rng = np.random.default_rng(11)
    base_scene = parse_scene(scene_doc("pr2", TABLE_X))
    far = clutter(rng, 10_000, lo=(4.0, -6.0), hi=(9.0, 6.0), sizes=(0.01, 0.0100001))
    scene = dataclasses.replace(base_scene, obstacles=base_scene.obstacles + tuple(far))
    plain = SceneCollision(pr2, base_scene, padding=0.005)
    fast, slow = checkers(pr2, scene, 0.005)
    assert len(plain.shapes) < GRID_PIECES  # the clutter-free scene is checked piece by piece
    arm = pr2.arm("right")
    runs = [
        (
            np.array([q, np.clip(q + 0.1, arm.lower, arm.upper)]),
            (TABLE_X - 0.3 - rng.uniform(0.3, 0.6), rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4)),
        )
        for q in random_configs(arm, 15, rng)
    ]
    times = {}
    for name, c in (("plain", plain), ("fast", fast), ("slow", slow)):
        c.check("right", *runs[0])
        t = time.process_time()
        results = [c.check("right", qs, base, grasped="cup_1") for qs, base in runs]
        times[name] = (time.process_time() - t) / len(runs)
        times[name + "_results"] = results
    assert times["fast_results"] == times["slow_results"] == times["plain_results"]
    assert times["fast"] < 2.0 * times["plain"] + 2e-3, times
    assert times["slow"] > 3 * times["fast"], times  # the prefilter is what makes the difference
    for qs, base in runs[:5]:
        A = fast.geometry.base_in_model @ np.linalg.inv(_base(base))
        inst = fast._instances("right", qs, fast.geometry.arm_shapes("right"))
        assert len(fast._scene_in_model(A, inst)["shapes"]) <= len(plain.shapes)
