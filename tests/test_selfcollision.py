"""Optional self-collision rejection (SPEC section 3, item 5): a hard reject while building maps."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import random_configs

import placement
from placement.selfcollision import SelfCollision


@pytest.fixture(scope="module")
def checker():
    return SelfCollision(placement.load_robot("pr2"), "right")


def test_collides_matches_pinocchio_on_all_pairs_it_keeps(checker, pr2):
    """Same verdicts as an independent pinocchio call; the excluded pairs are the documented ones."""
    arm = pr2.arm("right")
    Q = random_configs(arm, 300, np.random.default_rng(21))
    got = checker.collides(Q)
    model = pr2.model
    geom = checker.geom
    data, gdata = model.createData(), pin.GeometryData(geom)
    moved = checker._moved_joints(model, arm.joint_ids)
    left_only = checker._moved_joints(model, pr2.arm("left").joint_ids) - moved
    for q, hit in zip(Q, got):
        qf = pr2.full_q("right", q)
        expect = pin.computeCollisions(model, data, geom, gdata, qf, False)
        assert hit == expect
    # both outcomes occur on random configurations: the test is not vacuous
    assert 0 < got.sum() < len(Q)
    for cp in geom.collisionPairs:
        j1 = geom.geometryObjects[cp.first].parentJoint
        j2 = geom.geometryObjects[cp.second].parentJoint
        assert j1 in moved or j2 in moved
        assert j1 not in left_only and j2 not in left_only
        assert j1 != j2 and model.parents[j1] != j2 and model.parents[j2] != j1


def test_home_is_free_and_hand_in_torso_collides(checker, pr2):
    arm = pr2.arm("right")
    assert not checker.collides(arm.home)[0]
    # a gripper near the body's vertical axis collides far more often than one out in the workspace
    Q = random_configs(arm, 1500, np.random.default_rng(5))
    hits = checker.collides(Q)
    tcp = np.array([pr2.tcp_pose("right", q)[:3, 3] for q in Q])
    inside = (np.abs(tcp[:, 0]) < 0.2) & (np.abs(tcp[:, 1]) < 0.2) & (tcp[:, 2] > 0.3) & (tcp[:, 2] < 1.0)
    assert inside.sum() >= 10
    assert hits[inside].mean() > hits[~inside].mean() + 0.2


def test_map_with_self_collision_is_the_max_over_free_samples(pr2, checker):
    """Equal, cell by cell, to a brute-force max over the collision-free samples (direct measure)."""
    from placement.build import default_grid
    from placement.kernels.grid import cell_indices
    from placement.kernels.kinematics import fk_jacobian_batch
    from placement.kernels.sampling import sample_configs

    n, res = 3000, 0.2
    built = placement.build_map(pr2, "right", samples=n, seed=4, resolution=res, progress=False,
                                self_collision=True, block=512)
    assert built.meta["measure"]["self_collision"] is True
    assert "collision shapes" in built.meta["measure"]["self_collision_geometry"]
    arm = pr2.arm("right")
    Q = sample_configs(np.uint64(4), 0, n, arm.lower, arm.upper)
    free = ~checker.collides(Q)
    assert 0 < (~free).sum() < n
    ch = arm.chain
    T, _ = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    grid = default_grid(pr2, "right", res)
    cells = cell_indices(T, grid.origin_array, grid.resolution, grid.shape_array)
    vals = np.float32(placement.extended_manipulability(pr2, "right", Q))
    expect = np.zeros(grid.size, np.float32)
    np.maximum.at(expect, cells[free], vals[free])
    assert np.array_equal(built.values.ravel(), expect)
    plain = placement.build_map(pr2, "right", samples=n, seed=4, resolution=res, progress=False)
    assert np.all(built.values <= plain.values) and np.any(built.values < plain.values)


def test_missing_collision_geometry_is_one_clear_error(armar6):
    with pytest.raises(placement.PlacementError, match="collision geometry"):
        SelfCollision(armar6, "right")
