"""The collision check's broad phase (placement.kernels.broadphase) against numpy's: the same pairs in
the same order with the same bounds, bit for bit, on random shapes and boxes and on the pairs of real
PR2 checks around a table."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from support.collision import box_distance, boxes_distance, scene_doc

import placement.collision.pairs as pairs_module
from placement.collision import SceneCollision
from placement.collision.pairs import self_instances
from placement.kernels.broadphase import scene_pair_bounds, self_pair_bounds
from placement.scene import load_scene


def numpy_pairs(inst, scene, shapes, ngeoms, cap, grasped, gone):
    """The broad phase in numpy (what the kernels replaced): robot-scene pairs, then self pairs."""
    centre, ext, radius = inst["centre"], inst["extent"], inst["radius"]
    lb = np.maximum(box_distance(centre, scene["aabb"]) - radius[:, None], boxes_distance(centre, ext, scene["aabb"]))
    if gone:
        lb[:, [i for i, o in enumerate(scene["objects"]) if o in gone]] = np.inf
    if grasped is not None:
        held = np.array([o == grasped for o in scene["objects"]], dtype=bool)
        lb[np.ix_(inst["gripper"], held)] = np.inf
    a, b = np.nonzero(lb <= cap)
    sa, sb = self_instances(shapes, inst["poses"], ngeoms)
    c, r = centre, radius
    gap = np.maximum(np.abs(c[sa] - c[sb]) - ext[sa] - ext[sb], 0.0)
    self_lb = np.maximum(np.linalg.norm(c[sa] - c[sb], axis=1) - r[sa] - r[sb], np.linalg.norm(gap, axis=1))
    keep = self_lb <= cap
    return {
        "a": np.concatenate([a, sa[keep]]),
        "b": np.concatenate([b, sb[keep]]),
        "self": np.concatenate([np.zeros(len(a), bool), np.ones(int(keep.sum()), bool)]),
        "lb": np.concatenate([lb[a, b], self_lb[keep]]),
    }


@pytest.mark.parametrize("seed", range(6))
def test_the_scene_and_self_bounds_are_numpys(seed):
    rng = np.random.default_rng(seed)
    n, s = int(rng.integers(0, 60)), int(rng.integers(0, 12))
    centre = rng.uniform(-1.0, 1.0, (n, 3))
    extent = rng.uniform(0.0, 0.2, (n, 3))
    radius = np.linalg.norm(extent, axis=1) * rng.uniform(1.0, 1.5, n)
    lo = rng.uniform(-1.0, 1.0, (s, 3))
    aabb = np.stack([lo, lo + rng.uniform(0.0, 0.5, (s, 3))], axis=1)
    aabb[: s // 3, 0, 2] = centre[0, 2] if n else 0.0  # a box face through a centre: zero terms
    skipped, held = rng.random(s) < 0.2, rng.random(s) < 0.3
    gripper = rng.random(n) < 0.3
    cap = 0.2
    want = np.maximum(box_distance(centre, aabb) - radius[:, None], boxes_distance(centre, extent, aabb))
    want[:, skipped] = np.inf
    want[np.ix_(gripper, held)] = np.inf
    wa, wb = np.nonzero(want <= cap)
    a, b, lb = scene_pair_bounds(centre, extent, radius, aabb, skipped, gripper, held, cap)
    assert np.array_equal(a, wa) and np.array_equal(b, wb) and np.array_equal(lb, want[wa, wb])
    first, second = rng.integers(0, max(n, 1), (2, 200)) if n else np.zeros((2, 0), np.int64)
    first, second = first.astype(np.int64), second.astype(np.int64)
    d = centre[first] - centre[second]
    gap = np.maximum(np.abs(d) - extent[first] - extent[second], 0.0)
    self_want = np.maximum(np.linalg.norm(d, axis=1) - radius[first] - radius[second], np.linalg.norm(gap, axis=1))
    kept, self_lb = self_pair_bounds(centre, extent, radius, first, second, cap)
    assert np.array_equal(kept, np.flatnonzero(self_want <= cap)) and np.array_equal(self_lb, self_want[kept])


def test_real_checks_pair_as_numpy_pairs_them(tmp_path, pr2, monkeypatch):
    """Random PR2 configurations before a table with a crate: each check's pairs equal numpy's, the
    grasped object and carried-away objects among them."""
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump(scene_doc("pr2", 0.6)))
    scene = load_scene(path)
    checker = SceneCollision(pr2, scene)
    objects = [o.name for o in scene.objects]
    compared = []
    kernel = pairs_module.candidate_pairs

    def both(inst, scene_pieces, shapes, ngeoms, cap, grasped, gone):
        got = kernel(inst, scene_pieces, shapes, ngeoms, cap, grasped, gone)
        want = numpy_pairs(inst, scene_pieces, shapes, ngeoms, cap, grasped, gone)
        compared.append(all(np.array_equal(got[k], want[k]) for k in ("a", "b", "self", "lb")) and len(want["a"]) > 0)
        return got

    monkeypatch.setattr("placement.collision.checker.candidate_pairs", both)
    rng = np.random.default_rng(3)
    for k in range(40):
        arm = sorted(pr2.arms)[k % 2]
        a = pr2.arm(arm)
        qs = np.clip(a.home + rng.normal(0.0, 0.6, size=(2, a.dof)), a.lower, a.upper)
        base = (float(rng.uniform(-0.5, 0.0)), float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)))
        grasped = objects[k % len(objects)] if k % 3 == 0 else None
        gone = objects[:1] if k % 4 == 1 else ()
        checker.check(arm, qs, base, grasped=grasped, gone=gone)
    assert len(compared) == 40 and all(compared)
