"""The broad phase's lower bounds never exceed the distances coal measures (placement/collision/pairs.py,
placement/kernels/broadphase.py)."""

from __future__ import annotations

import coal
import numpy as np
import pytest
from support.planning import write_scene

from placement.collision import SceneCollision
from placement.collision.bounds import base_matrix
from placement.kernels.broadphase import scene_pair_bounds
from placement.scene import load_scene


def test_the_box_bound_is_coals_box_distance():
    """The kernel's bound of a shape whose sphere says nothing (an infinite radius) is its box's
    distance to the piece's box, as coal measures it."""
    rng = np.random.default_rng(3)
    no = np.zeros(1, bool)
    for _ in range(200):
        c, e = rng.uniform(-1, 1, 3), rng.uniform(0.01, 0.5, 3)
        lo = rng.uniform(-1, 1, 3)
        hi = lo + rng.uniform(0.01, 0.8, 3)
        _, _, lb = scene_pair_bounds(c[None], e[None], np.array([np.inf]), np.array([[lo, hi]]), no, no, no, np.inf)
        got = lb[0]
        req, res = coal.DistanceRequest(), coal.DistanceResult()
        want = coal.distance(
            coal.Box(*(2 * e)),
            coal.Transform3s(np.eye(3), c),
            coal.Box(*(hi - lo)),
            coal.Transform3s(np.eye(3), (lo + hi) / 2),
            req,
            res,
        )
        assert got == np.float64(0.0) if want <= 0 else abs(got - want) < 1e-9


@pytest.mark.slow
def test_every_pairs_bound_is_below_its_distance(tmp_path, maps_dir, pr2):
    scene = load_scene(write_scene(tmp_path, maps_dir))
    c = SceneCollision(pr2, scene)
    rng = np.random.default_rng(11)
    checked = 0
    for k in range(24):
        arm = sorted(pr2.arms)[k % 2]
        a = pr2.arm(arm)
        qs = np.clip(a.home + rng.normal(0.0, 0.6, size=(2, a.dof)), a.lower, a.upper)
        base = (float(rng.uniform(2.0, 2.5)), float(rng.uniform(1.6, 3.4)), float(rng.uniform(-np.pi, np.pi)))
        A = c.geometry.base_in_model @ np.linalg.inv(base_matrix(*base))
        shapes = c.geometry.arm_shapes(arm)
        inst = c._instances(arm, qs, shapes)
        sc = c._scene_in_model(A, inst)
        pairs = c._pairs(inst, sc, shapes, None, frozenset())
        for p in range(len(pairs["lb"])):
            (g1, _, _, T1), (g2, _, _, T2) = c._operands(pairs, p, inst, sc)
            d = c._distance(g1, T1, g2, T2)
            assert pairs["lb"][p] <= max(d, 0.0) + 1e-9, (c._name(pairs, p, inst, sc), pairs["lb"][p], d)
            checked += 1
    assert checked > 500
