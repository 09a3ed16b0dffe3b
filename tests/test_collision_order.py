"""The check runs the collision tests of the pairs within the padding first and measures the closest
pair only when none collides: the same results as measuring the closest pair first and testing for
collisions only when it lies within the padding (the order before), on random configurations."""

from __future__ import annotations

import numpy as np
import pytest
from support.planning import write_scene

from placement.collision import SceneCollision
from placement.collision.bounds import base_matrix
from placement.scene import load_scene


def distances_then_collisions(c: SceneCollision, arm, qs, base, grasped=None):
    """The check with the closest pair measured before the collision tests (the order it had before),
    which are skipped when that pair lies beyond the padding (by more than coal's tolerance)."""
    A = c.geometry.base_in_model @ np.linalg.inv(base_matrix(*base))
    shapes = c.geometry.arm_shapes(arm)
    inst = c._instances(arm, np.atleast_2d(qs), shapes)
    scene = c._scene_in_model(A, inst)
    pairs = c._pairs(inst, scene, shapes, grasped, frozenset())
    free = c._closest(pairs, inst, scene)
    if free.clearance_m <= c.padding + 1e-4:
        hit = c._first_collision(pairs, inst, scene)
        if hit is not None:
            return hit
    return free


@pytest.mark.parametrize("padding", [0.0, 0.03])
def test_collisions_first_give_the_same_results(tmp_path, maps_dir, pr2, padding):
    scene = load_scene(write_scene(tmp_path, maps_dir))
    c = SceneCollision(pr2, scene, padding=padding)
    rng = np.random.default_rng(7)
    seen = {True: 0, False: 0}
    for k in range(60):
        arm = sorted(pr2.arms)[k % 2]
        a = pr2.arm(arm)
        qs = np.clip(a.home + rng.normal(0.0, 0.6, size=(2, a.dof)), a.lower, a.upper)
        # bases around the table (3.0, 2.5), 0.8 m x 0.6 m: some arms reach into it
        base = (float(rng.uniform(2.0, 2.5)), float(rng.uniform(1.6, 3.4)), float(rng.uniform(-np.pi, np.pi)))
        got, want = c.check(arm, qs, base, grasped="cup"), distances_then_collisions(c, arm, qs, base, grasped="cup")
        assert (got.free, got.clearance_m, got.culprit, got.pose) == (
            want.free,
            want.clearance_m,
            want.culprit,
            want.pose,
        )
        seen[got.free] += 1
    assert seen[True] >= 10 and seen[False] >= 10, seen  # both kinds of result were compared
