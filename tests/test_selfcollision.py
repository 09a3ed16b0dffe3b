"""Optional self-collision rejection (docs/maps.md): a hard reject while building maps."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from support.robots import random_configs

import placement
from placement.maps.selfcollision import SelfCollision


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


@pytest.mark.slow
def test_map_with_self_collision_is_the_max_over_free_samples(pr2, checker):
    """Equal, cell by cell, to a brute-force max over the collision-free samples (direct measure)."""
    from placement.kernels.grid import cell_indices
    from placement.kernels.kinematics import fk_jacobian_batch
    from placement.kernels.sampling import sample_configs
    from placement.maps.build import default_grid

    n, res = 3000, 0.2
    built = placement.build_map(
        pr2, "right", samples=n, seed=4, resolution=res, progress=False, self_collision=True, block=512
    )
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


def test_distance_penalty_literal():
    from placement.maps.selfcollision import distance_penalty

    assert distance_penalty(0.05) == pytest.approx(np.exp(-2.0) / 0.05, rel=1e-15)
    assert distance_penalty(0.2) == pytest.approx(np.exp(-8.0) / 0.2, rel=1e-15)


@pytest.mark.slow
def test_row_factors_against_pinocchio_distances(checker, pr2):
    """Rotation rows untouched; translational rows penalised towards the body only, by P(d) |n_r|."""
    from placement.maps.selfcollision import distance_penalty

    arm = pr2.arm("right")
    Q = random_configs(arm, 200, np.random.default_rng(8))
    rf = checker.row_factors(Q)
    hits = checker.collides(Q)
    assert np.array_equal(rf[:, 0, 0] < 0, hits) and hits.any()
    model, geom = pr2.model, checker.geom
    data, gdata = model.createData(), pin.GeometryData(geom)
    for q, f, hit in zip(Q, rf, hits):
        if hit:
            continue
        assert np.all(f[3:] == 1.0) and np.all((f > 0) & (f <= 1.0))
        assert np.all((f[:3, 0] == 1.0) | (f[:3, 1] == 1.0))  # only one sign of a row approaches
        pin.computeDistances(model, data, geom, gdata, pr2.full_q("right", q))
        all_d = [r.min_distance for r in gdata.distanceResults]
        d = min(all_d)
        # the bounding-sphere pruned search finds the same pair as measuring every pair
        k, res = checker._nearest_pair(
            pr2.full_q("right", q), np.empty_like(checker._centre), checker._pair_ids[:, 0], checker._pair_ids[:, 1]
        )
        assert k == int(np.argmin(all_d)) and res.min_distance == d
        # (1/f^2 - 1) = P(d) |n_r| summed over both signs, and |n| = 1
        pn = (1.0 / f[:3, 0] ** 2 - 1.0) + (1.0 / f[:3, 1] ** 2 - 1.0)
        assert np.sqrt(np.sum(pn**2)) == pytest.approx(distance_penalty(d), rel=1e-9, abs=1e-12)


@pytest.mark.slow
def test_map_with_self_distance_is_the_max_over_penalised_samples(pr2, checker):
    """A build with the self-distance penalty equals the brute-force per-cell max of penalised values."""
    from placement.kernels.grid import cell_indices
    from placement.kernels.kinematics import fk_jacobian_batch
    from placement.kernels.sampling import sample_configs
    from placement.maps.build import default_grid

    n, res = 1500, 0.2
    built = placement.build_map(
        pr2, "right", samples=n, seed=9, resolution=res, progress=False, self_distance=True, block=400
    )
    assert built.meta["measure"]["self_distance_penalty"]["alpha_per_m"] == 40.0
    arm = pr2.arm("right")
    Q = sample_configs(np.uint64(9), 0, n, arm.lower, arm.upper)
    rf = checker.row_factors(Q)
    free = rf[:, 0, 0] >= 0
    vals = np.float32(placement.extended_manipulability(pr2, "right", Q[free], row_factors=rf[free]))
    ch = arm.chain
    T, _ = fk_jacobian_batch(Q[free], ch.link_T, ch.axis, ch.kind, ch.tip_T)
    grid = default_grid(pr2, "right", res)
    cells = cell_indices(T, grid.origin_array, grid.resolution, grid.shape_array)
    expect = np.zeros(grid.size, np.float32)
    np.maximum.at(expect, cells, vals)
    assert np.array_equal(built.values.ravel(), expect)
    collision_only = placement.build_map(
        pr2, "right", samples=n, seed=9, resolution=res, progress=False, self_collision=True
    )
    assert np.any(built.values != collision_only.values)  # the penalty changes values
    assert np.array_equal(built.values > 0, collision_only.values > 0)  # but not which cells are reached


def test_no_pair_left_is_one_clear_error(tmp_path):
    """Shapes only on the base and the first arm link (adjacent): nothing to test, a clear error."""
    box = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    links = "".join(f'<link name="l{i}">{box if i < 2 else ""}</link>' for i in range(8))
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        f'<origin xyz="0 0 0.3"/><axis xyz="{"0 0 1" if i % 2 == 0 else "0 1 0"}"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(7)
    )
    urdf = tmp_path / "chain.urdf"
    urdf.write_text(f'<robot name="chain">{links}{joints}</robot>')
    preset = tmp_path / "chain.yaml"
    preset.write_text(
        f"name: chain\nurdf: {urdf}\nbase_frame: l0\nfootprint_radius: 0.3\nv_max: 0.5\nomega_max: 1.0\n"
        "arms:\n  a:\n    joints: [j0, j1, j2, j3, j4, j5, j6]\n    tip_frame: l7\n"
    )
    robot = placement.load_robot(str(preset))
    with pytest.raises(placement.PlacementError, match="no collision shape pair involves arm 'a'"):
        SelfCollision(robot, "a")
