"""Map building: reproducible however the work is split, and equal to a slow reference (docs/maps.md)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

import placement
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.sampling import sample_configs

SEED = 5
N = 30000
N_SMALL = 10000
SMALL = dict(resolution=0.25, bins=(4, 3, 4))  # a coarse grid: many samples share a cell (pruning acts)


def build(robot, arm="right", samples=N, seed=SEED, threads=None, **kw):
    old = numba.get_num_threads()
    try:
        if threads is not None:
            numba.set_num_threads(threads)
        return placement.build_map(robot, arm, samples=samples, seed=seed, progress=False, **kw)
    finally:
        numba.set_num_threads(old)


@pytest.fixture(scope="module")
def built(pr2):
    """The default-grid PR2 right-arm map, 30000 samples, seed 5, all threads, default block."""
    return build(pr2)


@pytest.fixture(scope="module")
def built_small(pr2):
    """The same on a coarse grid with 10000 samples."""
    return build(pr2, samples=N_SMALL, **SMALL)


def assert_bitwise_equal(a: np.ndarray, b: np.ndarray):
    assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
    diff = np.flatnonzero(a.view(np.uint32) != b.view(np.uint32))
    assert diff.size == 0, (
        f"{diff.size} cells differ, first at flat index {diff[:5]}: {a.ravel()[diff[:5]]} vs {b.ravel()[diff[:5]]}"
    )


# --------------------------------------------------------------------------------------------


@pytest.mark.slow
def test_default_resolution_is_5cm(built):
    """5 cm cells by default (as maps/pr2.yaml; maps/pr2-10cm.yaml chooses 0.1 m)."""
    assert built.grid.resolution == 0.05


def test_map_is_not_trivial(built, built_small):
    for m, n in ((built, N), (built_small, N_SMALL)):
        v = m.values
        assert v.dtype == np.float32 and v.shape == m.grid.shape
        assert 0 < np.count_nonzero(v) <= n
        assert m.meta["filled_cells"] == np.count_nonzero(v)
        assert 0 < v.max() <= 1.0 and v.min() == 0.0
        assert m.meta["samples"] == n and m.meta["seed"] == SEED
    # on the coarse grid many samples share a cell: the per-cell maximum and the pruning are exercised
    assert np.count_nonzero(built_small.values) < 0.6 * N_SMALL


@pytest.mark.slow
@pytest.mark.parametrize("grid", ["default", "small"])
def test_thread_count_does_not_change_the_map(pr2, built, built_small, grid):
    kw = dict(samples=N_SMALL, **SMALL) if grid == "small" else {}
    ref = built_small if grid == "small" else built
    one = build(pr2, threads=1, **kw)
    assert_bitwise_equal(one.values, ref.values)
    del one
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has a single thread here: cannot compare 1 vs 2 threads")
    two = build(pr2, threads=2, **kw)
    assert_bitwise_equal(two.values, ref.values)


@pytest.mark.slow
def test_block_size_does_not_change_the_map(pr2, built):
    """``built`` ran as one block of 30000 (the default block is larger than the sample count)."""
    assert_bitwise_equal(build(pr2, block=4096).values, built.values)


@pytest.mark.parametrize("block", [N_SMALL, 4096, 1000, 7])
def test_block_size_does_not_change_the_map_small_grid(pr2, built_small, block):
    samples = N_SMALL if block >= 1000 else 1500
    ref = built_small if samples == N_SMALL else build(pr2, samples=samples, **SMALL)
    other = build(pr2, samples=samples, block=block, **SMALL)
    assert_bitwise_equal(other.values, ref.values)


def test_prefix_property(pr2, built_small):
    """Sample i is a function of (seed, i): the map of the first 3000 samples is below the full one."""
    first = build(pr2, samples=3000, **SMALL).values
    assert np.all(first <= built_small.values)
    assert np.count_nonzero(first) < np.count_nonzero(built_small.values)


def test_different_seeds_differ(pr2, built_small):
    other = build(pr2, samples=N_SMALL, seed=SEED + 1, **SMALL)
    assert other.values.shape == built_small.values.shape
    assert np.count_nonzero(other.values != built_small.values) > 0.5 * np.count_nonzero(built_small.values)
    assert other.meta["seed"] == SEED + 1


def _check_samples_under_map(robot, arm_name, m, n):
    arm = robot.arm(arm_name)
    Q = sample_configs(np.uint64(m.meta["seed"]), 0, n, arm.lower, arm.upper)
    assert Q.shape == (n, arm.dof)
    assert np.all(Q >= arm.lower) and np.all(Q <= arm.upper)
    ch = arm.chain
    T, _ = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    cells = m.grid.index(T)
    assert np.all(cells >= 0)
    vals = np.float32(placement.extended_manipulability(robot, arm_name, Q))
    flat = m.values.ravel()
    bad = np.flatnonzero(flat[cells] < vals)
    assert bad.size == 0, (
        f"{bad.size} samples exceed their cell, e.g. sample {bad[0]}: {vals[bad[0]]} > {flat[cells[bad[0]]]}"
    )
    # every filled cell holds the value of one of the samples (the maximum of its samples)
    best = np.zeros(flat.size, dtype=np.float32)
    np.maximum.at(best, cells, vals)
    assert_bitwise_equal(best.reshape(m.values.shape), m.values)


@pytest.mark.slow
def test_every_sample_is_below_its_cell(pr2, built):
    _check_samples_under_map(pr2, "right", built, N)


@pytest.mark.slow
def test_every_sample_is_below_its_cell_small_grid(pr2, built_small):
    _check_samples_under_map(pr2, "right", built_small, N_SMALL)


@pytest.mark.slow
@pytest.mark.parametrize(
    "kw,index",
    [({}, "isotropy"), (SMALL, "isotropy"), (SMALL, "volume")],
    ids=["default-grid", "small-grid", "small-grid-volume"],
)
def test_equals_slow_reference_map(pr2, kw, index):
    """Build a map the slow way (pinocchio FK, Grid.index, per-sample value, python max) and compare."""
    n, seed = 3000, 11
    m = build(pr2, samples=n, seed=seed, index=index, **kw)
    assert m.meta["measure"]["index"] == index
    arm = pr2.arm("right")
    Q = sample_configs(np.uint64(seed), 0, n, arm.lower, arm.upper)
    ref = {}
    for q in Q:
        cell = int(m.grid.index(pr2.tcp_pose("right", q))[0])
        assert cell >= 0
        v = np.float32(placement.extended_manipulability(pr2, "right", q, index=index))
        if v > 0:
            ref[cell] = max(ref.get(cell, np.float32(0)), v)
    flat = m.values.ravel()
    nz = np.flatnonzero(flat)
    assert sorted(ref) == nz.tolist()
    np.testing.assert_array_equal(flat[nz], np.array([ref[c] for c in nz.tolist()], dtype=np.float32))
    if kw:  # pruning on a shared-cell grid does not depend on the block split, for either index
        assert_bitwise_equal(build(pr2, samples=n, seed=seed, index=index, block=500, **kw).values, m.values)


def test_samples_are_uniform_within_limits(pr2):
    arm = pr2.arm("right")
    Q = sample_configs(np.uint64(1), 0, 20000, arm.lower, arm.upper)
    u = (Q - arm.lower) / (arm.upper - arm.lower)
    assert np.all((u >= 0) & (u < 1))
    np.testing.assert_allclose(u.mean(axis=0), 0.5, atol=0.01)
    np.testing.assert_allclose(u.var(axis=0), 1 / 12, atol=0.003)
    # joints are not correlated and offsets continue the same stream
    assert np.abs(np.corrcoef(u.T) - np.eye(arm.dof)).max() < 0.03
    np.testing.assert_array_equal(sample_configs(np.uint64(1), 500, 100, arm.lower, arm.upper), Q[500:600])


@pytest.mark.slow
def test_armar6_map_both_arms(armar6):
    maps = {arm: build(armar6, arm, samples=4000, seed=3, **SMALL) for arm in armar6.arms}
    assert set(maps) == {"left", "right"}
    for arm, m in maps.items():
        assert m.meta["arm"] == arm and m.meta["robot"] == "armar6" and m.meta["base_frame"] == "platform"
        assert m.meta["joints"] == armar6.arm(arm).joints and len(m.meta["joints"]) == 8
        assert m.meta["fixed_joints"] == {"torso_joint": -0.2}
        assert 0 < np.count_nonzero(m.values) <= 4000
        _check_samples_under_map(armar6, arm, m, 4000)
    # the arms are mirror images across the platform's sagittal plane: their maps differ
    l_, r_ = maps["left"], maps["right"]
    assert l_.grid != r_.grid or np.any(l_.values != r_.values)


def test_bad_arguments(pr2):
    for samples in (0, -3, placement.maps.buildspec.MAX_SAMPLES + 1):
        with pytest.raises(placement.PlacementError, match="samples must be a whole number from 1"):
            placement.build_map(pr2, "right", samples=samples, progress=False)
    for kw in ({"samples": 10.0}, {"samples": True}, {"seed": 1.5}, {"seed": "1"}):
        with pytest.raises(placement.PlacementError, match="must be integers"):
            placement.build_map(pr2, "right", **{"samples": 10, **kw}, progress=False)
    with pytest.raises(placement.PlacementError, match="seed must be a whole number from 0"):
        placement.build_map(pr2, "right", samples=10, seed=-1, progress=False)
    with pytest.raises(placement.PlacementError, match="index"):
        placement.build_map(pr2, "right", samples=10, index="nope", progress=False)
    with pytest.raises(placement.ArmNotFound):
        placement.build_map(pr2, "middle", samples=10, progress=False)
