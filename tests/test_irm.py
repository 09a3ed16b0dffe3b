"""The sliced inverse-reachability map equals direct 6D lookups of the inverted poses."""

from __future__ import annotations

import math

import numpy as np
import pytest

import placement
from placement.maps.grid import pose_from_zyx
from placement.planning.problems.manipulation import base_yaws, manipulation_map
from placement.scene.navgrid import NavGrid


@pytest.fixture(scope="module")
def coarse_map(pr2, tmp_path_factory):
    built = placement.build_map(pr2, "right", samples=600_000, seed=2, resolution=0.1, bins=(10, 5, 10), progress=False)
    path = placement.save_maps(tmp_path_factory.mktemp("m") / "pr2", pr2, {"right": built})
    return placement.open_map(path, "right", pr2)


def _planar(x, y, a):
    T = np.eye(4)
    T[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    T[:2, 3] = (x, y)
    return T


@pytest.mark.slow
def test_sliced_irm_equals_direct_lookup(coarse_map):
    rng = np.random.default_rng(3)
    nav = NavGrid((-1.5, -1.5), 0.1, (30, 30))
    yaws = base_yaws(40)
    # a top grasp above a table and its pre-grasp, at a random yaw
    yaw = rng.uniform(-math.pi, math.pi)
    # positions off the 0.1 m lattice: a base yaw of 45 deg must not put a pose exactly on a cell edge
    traj = pose_from_zyx(
        np.array([[0.1234, 0.2345, 0.95], [0.1234, 0.2345, 0.85]]), [yaw, yaw], [0.0, 0.0], [math.pi, math.pi]
    )
    val, arg = manipulation_map(coarse_map, traj, nav, yaws, cells=np.arange(900))
    xs, ys = nav.centres()
    reached = 0
    for iy in range(30):
        for ix in range(30):
            per_yaw = []
            for a in yaws:
                base = _planar(xs[ix], ys[iy], a)
                local = np.linalg.inv(base) @ traj
                per_yaw.append(coarse_map.value(local).min())
            best = max(per_yaw)
            assert val[iy, ix] == pytest.approx(best, abs=0), (iy, ix)
            if best > 0:
                reached += 1
                assert per_yaw[arg[iy, ix]] == best
            else:
                assert arg[iy, ix] == -1
    assert reached > 20


def test_candidates_evaluated_together_equal_each_alone(coarse_map):
    """Place candidates (8 gripper yaws, one slice) and grasps at other heights, all in one call:
    each result is bitwise the one-trajectory result (which the test above checks against 6D lookups)."""
    from placement.planning.problems.grasps import place_candidates, top_grasps
    from placement.planning.problems.manipulation import manipulation_maps
    from placement.scene.navgrid import Window

    nav = NavGrid((-1.5, -1.5), 0.1, (30, 30))
    yaws = base_yaws(40)
    trajs = [c.poses for c in place_candidates([0.1234, 0.2345, 0.9], 8)]
    trajs += [c.poses for c in top_grasps([0.1234, 0.2345, 0.7], 0.4, [0.05, 0.1, 0.1])]
    trajs.append(trajs[0].copy())
    trajs[-1][:, 2, 3] += 5.0  # out of the map's height range: zeros
    cells = np.arange(30, 870)
    window = Window(1, 29, 0, 30)
    together = manipulation_maps(coarse_map, trajs, nav, yaws, cells, window)
    for T, (val, arg) in zip(trajs, together):
        v1, a1 = manipulation_map(coarse_map, T, nav, yaws, cells, window)
        assert np.array_equal(val, v1) and np.array_equal(arg, a1)
    assert sum(int((v > 0).sum()) for v, _ in together[:8]) > 100 and not together[-1][0].any()


def test_a_steps_maps_in_one_pass_equal_each_alone_on_its_own_cells(coarse_map):
    """``reach_maps`` (a step's candidates at scattered targets, over the cells within any one's reach,
    one kernel pass, each kept over its own window) gives each candidate bit for bit its own map over
    the cells within its own reach (what the planner computed one target at a time before), and 0
    around it; a target off the map's heights gets an empty map."""
    from placement.planning.problems.grasps import place_candidates, top_grasps
    from placement.planning.problems.manipulation import cells_within, pose_reach, reach_maps
    from placement.scene.navgrid import Window

    rng = np.random.default_rng(5)
    nav = NavGrid((-2.0, -2.0), 0.05, (80, 80))
    yaws = base_yaws(40)
    trajs = [c.poses for c in place_candidates([0.1234, 0.2345, 0.9], 8)]
    for _ in range(6):  # grasps at other points and heights, alone in their groups
        x, y, z = rng.uniform(-0.2, 0.4), rng.uniform(-0.2, 0.4), rng.uniform(0.5, 1.1)
        trajs += [c.poses for c in top_grasps([x, y, z], rng.uniform(-3, 3), [0.05, 0.1, 0.1])]
    trajs.append(trajs[0].copy())
    trajs[-1][:, 2, 3] += 5.0
    union = np.unique(
        np.concatenate([cells_within(nav, T[-1, 0, 3], T[-1, 1, 3], pose_reach(coarse_map, T[-1])) for T in trajs[:-1]])
    )
    masks = rng.integers(0, 2**40, (len(union), 1)).astype(np.uint64)  # some yaws blocked per cell
    at = {int(c): k for k, c in enumerate(union)}
    reached = 0
    for T, (window, val, arg) in zip(trajs, reach_maps(coarse_map, trajs, nav, yaws, union, masks)()):
        r = pose_reach(coarse_map, T[-1])
        if r < 0:
            assert val.size == 0
            continue
        own = cells_within(nav, T[-1, 0, 3], T[-1, 1, 3], r)
        v1, a1 = manipulation_map(coarse_map, T, nav, yaws, own, Window(0, 80, 0, 80), masks[[at[int(c)] for c in own]])
        full_v, full_a = np.zeros((80, 80), np.float32), np.full((80, 80), -1, np.int16)
        full_v[window.slices], full_a[window.slices] = val, arg
        assert np.array_equal(full_v, v1) and np.array_equal(full_a, a1)
        reached += int((val > 0).sum())
    assert reached > 500


@pytest.mark.parametrize("share", [0.2, 0.5, 0.8])
def test_maps_asked_at_least_a_value_keep_the_same_cells(coarse_map, share):
    """``reach_maps(..., at_least=t)`` (the certificate's regions: a pass that stops at the first yaw
    keeping t) keeps exactly the cells where the best value is at least t, at a yaw whose own value
    (the plain arithmetic of :func:`yaw_values`) is the one returned and at least t; 0 and -1
    elsewhere. t at a share of the best value, and at a map value itself (ties: float32 against a
    float threshold, as the regions compare them)."""
    from placement.planning.problems.grasps import place_candidates, top_grasps
    from placement.planning.problems.manipulation import cells_within, pose_reach, reach_maps, yaw_values

    rng = np.random.default_rng(int(share * 10))
    nav = NavGrid((-2.0, -2.0), 0.05, (80, 80))
    yaws = base_yaws(40)
    trajs = [c.poses for c in place_candidates([0.1234, 0.2345, 0.9], 8)]
    trajs += [c.poses for c in top_grasps([0.05, -0.1, 0.75], 0.7, [0.05, 0.1, 0.1])]
    for _ in range(4):  # grasps at other points, alone in their groups (the kernel's one-member path)
        x, y, z = rng.uniform(-0.2, 0.4), rng.uniform(-0.2, 0.4), rng.uniform(0.6, 1.0)
        trajs.append(top_grasps([x, y, z], rng.uniform(-3, 3), [0.05, 0.1, 0.1])[0].poses)
    for yaw in (0.3, 2.0):  # side grasps: the pre-grasp 0.1 m back along the approach (two points)
        grasp = pose_from_zyx([[0.1 + 0.1 * yaw, -0.05, 0.85]], yaw, 0.0, 0.0)[0]
        pre = grasp.copy()
        pre[:3, 3] -= 0.1 * grasp[:3, 0]
        trajs.append(np.stack([pre, grasp]))
    union = np.unique(
        np.concatenate([cells_within(nav, T[-1, 0, 3], T[-1, 1, 3], pose_reach(coarse_map, T[-1])) for T in trajs])
    )
    masks = rng.integers(0, 2**40, (len(union), 1)).astype(np.uint64)
    full = reach_maps(coarse_map, trajs, nav, yaws, union, masks)()
    top = max(float(v.max()) for _, v, _ in full)
    values = np.unique(np.concatenate([v[v > 0] for _, v, _ in full]))
    for t in (share * top, float(values[int(share * (len(values) - 1))])):
        kept = reach_maps(coarse_map, trajs, nav, yaws, union, masks, at_least=t)()
        for T, (w, v, _), (w2, v2, a2) in zip(trajs, full, kept):
            assert w == w2
            assert np.array_equal(v >= t, v2 >= t) and np.array_equal(v2 > 0, v2 >= t)
            assert np.all(a2[v2 == 0] == -1) and np.all(a2[v2 > 0] >= 0)
            iy, ix = np.nonzero(v2)
            if iy.size:
                xs, ys = nav.centres()
                got = yaw_values(coarse_map, T, xs[ix + w.x0], ys[iy + w.y0], yaws)[np.arange(iy.size), a2[iy, ix]]
                assert np.array_equal(got, v2[iy, ix])
        assert sum(int((v2 >= t).sum()) for _, v2, _ in kept) > 10


def test_cells_beyond_the_slice_reach_are_zero(coarse_map):
    """Skipping base cells farther than the target slice's reach changes nothing: evaluated on every
    cell, those are exactly the cells left at 0 / -1."""
    from placement.planning.problems.grasps import top_grasps
    from placement.planning.problems.manipulation import cells_within, pose_reach

    nav = NavGrid((-2.0, -2.0), 0.05, (80, 80))
    yaws = base_yaws(40)
    for z in (0.55, 0.8, 1.1):
        T = top_grasps([0.1234, 0.2345, z], 0.4, [0.05, 0.1, 0.1])[0].poses
        r = pose_reach(coarse_map, T[-1])
        assert 0 < r < math.hypot(2.0, 2.0)
        full = manipulation_map(coarse_map, T, nav, yaws, cells=np.arange(80 * 80))
        near = manipulation_map(coarse_map, T, nav, yaws, cells=cells_within(nav, T[-1, 0, 3], T[-1, 1, 3], r))
        assert np.array_equal(full[0], near[0]) and np.array_equal(full[1], near[1])
        assert (full[0] > 0).sum() > 0


def test_irm_max_runs_over_each_cells_allowed_yaws(coarse_map):
    """Per-cell yaw masks (a polygon base fits at some yaws only): the value is the best allowed yaw's,
    checked against the direct lookup; masks allowing every yaw give the unmasked maps bit for bit."""
    rng = np.random.default_rng(8)
    nav = NavGrid((-1.5, -1.5), 0.1, (30, 30))
    yaws = base_yaws(70)  # two mask words
    traj = pose_from_zyx(
        np.array([[0.1234, 0.2345, 0.95], [0.1234, 0.2345, 0.85]]), [0.4, 0.4], [0.0, 0.0], [math.pi, math.pi]
    )
    cells = np.sort(rng.choice(900, 250, replace=False))
    bits = rng.random((250, 70)) < 0.4
    masks = np.zeros((250, 2), np.uint64)
    for k in range(70):
        masks[:, k >> 6] |= bits[:, k].astype(np.uint64) << np.uint64(k & 63)
    val, arg = manipulation_map(coarse_map, traj, nav, yaws, cells, masks=masks)
    full = np.full((250, 2), np.iinfo(np.uint64).max, np.uint64)
    assert [
        np.array_equal(a, b)
        for a, b in zip(
            manipulation_map(coarse_map, traj, nav, yaws, cells, masks=full),
            manipulation_map(coarse_map, traj, nav, yaws, cells),
        )
    ] == [True, True]
    xs, ys = nav.centres()
    reached = 0
    for n, c in enumerate(cells):
        iy, ix = divmod(int(c), 30)
        per_yaw = [
            coarse_map.value(np.linalg.inv(_planar(xs[ix], ys[iy], a)) @ traj).min() if bits[n, k] else 0.0
            for k, a in enumerate(yaws)
        ]
        assert val[iy, ix] == max(per_yaw)
        assert (
            (arg[iy, ix] == -1)
            if max(per_yaw) == 0
            else (bits[n, arg[iy, ix]] and per_yaw[arg[iy, ix]] == max(per_yaw))
        )
        reached += max(per_yaw) > 0
    assert reached > 20


@pytest.mark.parametrize(
    "positions, yaws_rad",
    [
        # a grasp under its pre-grasp, a third pose beside them: the first two merge, the third not
        ([[0.1234, 0.2345, 0.95], [0.1234, 0.2345, 0.75], [0.1734, 0.2345, 0.85]], [0.3, 0.3, 0.3]),
        # stacked poses at different yaws: nothing merges
        ([[0.1234, 0.2345, 0.95], [0.1234, 0.2345, 0.85]], [0.3, 1.9]),
        # the same pose twice (one z bin) and one stacked between: all three read one merged slice
        ([[0.1234, 0.2345, 0.95], [0.1234, 0.2345, 0.85], [0.1234, 0.2345, 0.95]], [-2.0, -2.0, -2.0]),
    ],
)
def test_stacked_poses_read_once_equal_direct_lookup(coarse_map, positions, yaws_rad):
    """Poses that differ only in height read one merged slice (their elementwise minimum); whether or
    not they merge, the map equals the direct 6D lookups of the inverted poses."""
    nav = NavGrid((-1.4, -1.4), 0.2, (14, 14))
    yaws = base_yaws(24)
    n = len(positions)
    traj = pose_from_zyx(np.array(positions), yaws_rad, [0.0] * n, [math.pi] * n)
    val, arg = manipulation_map(coarse_map, traj, nav, yaws, cells=np.arange(14 * 14))
    xs, ys = nav.centres()
    reached = 0
    for iy in range(14):
        for ix in range(14):
            per_yaw = [coarse_map.value(np.linalg.inv(_planar(xs[ix], ys[iy], a)) @ traj).min() for a in yaws]
            assert val[iy, ix] == max(per_yaw), (iy, ix)
            assert arg[iy, ix] == (per_yaw.index(max(per_yaw)) if max(per_yaw) > 0 else -1)
            reached += max(per_yaw) > 0
    assert reached > 5


def test_lowest_is_the_elementwise_minimum_of_the_slices(coarse_map):
    g = coarse_map.grid
    ip, ir = g.shape[4] // 2, 0
    zs = (g.shape[2] - 2, 1, g.shape[2] - 2)
    low = coarse_map.lowest(zs, ip, ir)
    expect = np.minimum(coarse_map.slice(1, ip, ir), coarse_map.slice(g.shape[2] - 2, ip, ir))
    assert low.dtype == np.float32 and np.array_equal(low, expect)
    assert coarse_map.lowest((1, g.shape[2] - 2), ip, ir) is low  # cached, whatever the order
    assert not low.flags.writeable
    assert np.array_equal(coarse_map.lowest((3,), ip, ir), coarse_map.slice(3, ip, ir))


def test_the_slab_holds_each_lowest_slice_once_and_stays_valid_as_it_grows(coarse_map):
    g = coarse_map.grid
    keys = [((z,), ip, ir) for z in range(g.shape[2]) for ip in (0, g.shape[4] - 1) for ir in (0, 3)]
    keys += [((1, 2), 0, 0), ((2, 1), 0, 0)]  # one key in two orders: one row
    slab, rows = coarse_map.stacked(keys[:5])
    first = slab[rows].copy()
    grown, all_rows = coarse_map.stacked(keys)
    assert grown.shape[0] >= len(keys) - 1
    assert np.array_equal(all_rows[:5], rows) and all_rows[-1] == all_rows[-2]
    assert len(set(all_rows.tolist())) == len(keys) - 1
    for key, row in zip(keys, all_rows):
        assert np.array_equal(grown[row], coarse_map.lowest(*key))
    assert np.array_equal(slab[rows], first)  # the slab given out before is as it was
    again, same = coarse_map.stacked(keys[::-1])
    assert again is grown and np.array_equal(same, all_rows[::-1])


def test_the_slab_is_made_for_the_slices_read_before(coarse_map):
    """A planner reads its task's slices when it is built: the slab's first rows are made for as many,
    so that stacking them all copies each once (no growth)."""
    fresh = placement.open_map(coarse_map.path, "right", coarse_map.robot)
    g = fresh.grid
    keys = [(z, ip, ir) for z in range(g.shape[2]) for ip in range(g.shape[4]) for ir in range(0, g.shape[5], 2)]
    fresh.read_slices(keys)
    slab, rows = fresh.stacked([((keys[0][0],), keys[0][1], keys[0][2])])
    assert slab.shape[0] >= len(keys)
    whole, all_rows = fresh.stacked([((z,), ip, ir) for z, ip, ir in keys])
    assert whole is slab and all_rows[0] == rows[0]
    for (z, ip, ir), row in zip(keys, all_rows):
        assert np.array_equal(whole[row], fresh.slice(z, ip, ir))


def run_kernel(
    slices, bits, bound, groups, members, tcp, member_yaw, yaws, cells, masks, above=0.0, first=False, polar=False
):
    """``trajectory_maps`` on a 16 x 15 grid of 0.1 m cells at (-0.75, -0.8) with maps of 0.1 m cells at
    (-0.6, -0.7): ``groups`` (G,) poses per group (pose p of a group reads slice p), ``members`` (G,)
    members per group, every group's bound ``bound`` (nx_rm, ny_rm), no disc; the slices in a slab
    of twice as many rows, shuffled among rows of noise; ``polar``: with each slice's polar bound (40
    rows per metre). Returns (values, yaws) (rows, 16, 15)."""
    from placement.kernels.irm import POLAR_ANGLES, polar_bound, trajectory_maps

    tables = (
        np.stack([polar_bound(s, -0.6, -0.7, 0.1, 40.0, POLAR_ANGLES) for s in slices])
        if polar
        else np.zeros((0, 0, 0), np.float32)
    )

    rows = int(sum(members))
    val = np.zeros((rows, 16, 15), np.float32)
    arg = np.full((rows, 16, 15), -1, np.int16)
    shuffle = np.random.default_rng(len(slices)).permutation(2 * len(slices))
    slab = np.random.default_rng(0).random((2 * len(slices), *slices.shape[1:])).astype(np.float32)
    slab[shuffle[: len(slices)]] = slices
    trajectory_maps(
        slab,
        shuffle[: len(slices)].astype(np.int64),
        bits,
        tables,
        40.0,
        bound[None],
        np.concatenate([np.arange(p, dtype=np.int64) for p in groups]),
        tcp[0],
        tcp[1],
        np.concatenate([[0], np.cumsum(groups)]).astype(np.int64),
        np.concatenate([[0], np.cumsum(members)]).astype(np.int64),
        np.arange(rows, dtype=np.int64),
        member_yaw,
        np.zeros(len(groups), dtype=np.int64),
        np.array([[0.0, 0.0, np.inf]] * len(groups)),
        np.array([-0.6, -0.7]),
        0.1,
        yaws,
        np.array([-0.75, -0.8]),
        0.1,
        15,
        cells,
        masks,
        val,
        arg,
        0,
        0,
        above,
        first,
    )
    return val, arg


@pytest.mark.slow
@pytest.mark.parametrize("poses, candidates", [(1, 1), (2, 1), (3, 1), (1, 8), (2, 2), (3, 5)])
def test_column_skip_changes_no_result(poses, candidates):
    """The kernel skips a base yaw whose first pose lands on a map column no higher than every
    candidate's best: on random sparse slices its results equal the kernel's without skips (an
    upper bound that never holds) bit for bit, values and best yaws."""
    rng = np.random.default_rng(poses * 10 + candidates)
    slices = rng.random((poses, 12, 14, 8)).astype(np.float32)
    slices[slices < 0.6] = 0.0  # sparse, like a map's slices
    slices = np.round(slices * 8) / 8  # ties between yaws: the first best yaw must win in both
    tcp = rng.uniform(-0.2, 0.2, (2, poses))
    tcp_yaw = rng.uniform(-math.pi, math.pi, (candidates, poses))
    yaws = base_yaws(36)
    cells = np.sort(rng.choice(16 * 15, 150, replace=False)).astype(np.int64)
    masks = rng.integers(0, 2**62, (150, 1)).astype(np.uint64)
    nobits = np.zeros((0, 0, 0), np.uint64)
    out = [
        run_kernel(slices, nobits, bound, [poses], [candidates], tcp, tcp_yaw.ravel(), yaws, cells, masks)
        for bound in (np.ascontiguousarray(slices[0].max(axis=2)), np.full((12, 14), np.inf, np.float32))
    ]
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
    assert (out[0][0] > 0).sum() > 20


def test_targets_far_apart_get_passes_of_their_own():
    """A step's candidates share a kernel pass when their targets lie within 0.5 m of the first one's
    (one object's grasps and places), not across a floor (a reach step's named trajectories)."""
    from placement.planning.problems.cache import _clusters
    from placement.planning.problems.grasps import Candidate

    def at(name, x, y):
        T = np.eye(4)[None].repeat(2, axis=0)
        T[:, 0, 3], T[:, 1, 3] = x, y
        return Candidate(name, T)

    a, b, c, d, e = at("a", 0, 0), at("b", 0.3, 0), at("c", 2.0, 0), at("d", 0.1, 0.1), at("e", 2.4, 0.2)
    assert [[k.name for k in g] for g in _clusters([a, b, c, d, e])] == [["a", "b", "d"], ["c", "e"]]
    assert _clusters([]) == []


@pytest.mark.parametrize("seed", range(6))
def test_farthest_reached_is_the_farthest_corner_of_a_reached_cell(seed):
    """The slice reach kernel against numpy: every reached (x, y) cell's farthest corner, the largest;
    -1 for an empty slice; grids that hold the origin or lie to one side of it."""
    from placement.kernels.irm import farthest_reached

    rng = np.random.default_rng(seed)
    nx, ny, nyaw = rng.integers(1, 30, 3)
    values = rng.random((nx, ny, nyaw)).astype(np.float32)
    values[values < rng.uniform(0.5, 1.0)] = 0.0
    x0, y0, res = rng.uniform(-1.5, 0.5), rng.uniform(-1.5, 0.5), rng.uniform(0.02, 0.2)
    jx, jy = np.nonzero(values.any(axis=2))
    xs = x0 + res * np.stack([jx, jx + 1])
    ys = y0 + res * np.stack([jy, jy + 1])
    want = np.sqrt(np.abs(xs).max(axis=0) ** 2 + np.abs(ys).max(axis=0) ** 2).max() if jx.size else -1.0
    assert farthest_reached(values, x0, y0, res) == want
    assert farthest_reached(np.zeros((nx, ny, nyaw), np.float32), x0, y0, res) == -1.0


@pytest.mark.parametrize("shape", [(1, 1, 1), (42, 43, 20), (7, 3, 9)])
def test_column_maxima_is_numpys_max_over_the_yaw_bins(shape):
    from placement.kernels.irm import column_maxima

    values = np.random.default_rng(sum(shape)).random(shape).astype(np.float32)
    values[values < 0.7] = 0.0
    got = column_maxima(values)
    assert got.dtype == np.float32 and np.array_equal(got, values.max(axis=2))


@pytest.mark.parametrize("poses", [1, 2, 3])
def test_a_threshold_pass_reading_yaw_bits_gives_what_it_gives_reading_values(poses):
    """A ``first`` pass of one-member groups reads which yaw bins lie above the threshold
    (``yaw_bits``: a bit per bin) until a yaw keeps every pose above it, and only then that yaw's
    values: on random sparse slices its values and yaws equal those of the pass reading values, bit
    for bit, and ``yaw_bits`` is numpy's comparison in float32."""
    from placement.kernels.irm import yaw_bits

    rng = np.random.default_rng(poses)
    slices = rng.random((poses, 12, 14, 20)).astype(np.float32)
    slices[slices < 0.5] = 0.0
    slices = np.round(slices * 16) / 16  # values equal to the threshold: not above it
    above = float(np.float32(0.5625))
    bits = np.stack([yaw_bits(s, above) for s in slices])
    weights = np.uint64(1) << np.arange(20, dtype=np.uint64)
    assert np.array_equal(bits, ((slices > np.float32(above)) * weights).sum(axis=3, dtype=np.uint64))
    G = 6  # six one-member groups at their own points
    tcp = rng.uniform(-0.2, 0.2, (2, G * poses))
    yaws = base_yaws(36)
    cells = np.sort(rng.choice(16 * 15, 150, replace=False)).astype(np.int64)
    masks = rng.integers(0, 2**36, (150, 1)).astype(np.uint64)
    member_yaw = np.linspace(-3.0, 3.0, G * poses)  # each pose its own TCP yaw [rad]
    out = [
        run_kernel(
            slices, given, slices[0].max(axis=2), [poses] * G, [1] * G, tcp, member_yaw, yaws, cells, masks, above, True
        )
        for given in (np.zeros((0, 0, 0), np.uint64), bits)
    ]
    assert np.array_equal(out[0][0], out[1][0]) and np.array_equal(out[0][1], out[1][1])
    assert (out[0][0] > above).sum() > 20 and ((out[0][0] == 0) & (out[0][1] == -1)).sum() > 20


@pytest.mark.parametrize("seed", range(8))
def test_the_polar_bound_holds_for_every_point_and_yaw_a_pose_can_read(seed):
    """``polar_bound`` against brute force: random points of a slice's cells (cell edges and corners
    among them) and random yaws, each read as the kernel reads it (the cell holding the point, the yaw
    bin of the angle): the table at the point's distance and relative angle (the angle less the
    point's bearing) is at least the value read, on grids around the origin and to one side of it."""
    from placement.kernels.grid import wrap_bin
    from placement.kernels.irm import polar_bound

    rng = np.random.default_rng(seed)
    nx, ny, nyaw = (int(v) for v in rng.integers(2, 25, 3))
    values = rng.random((nx, ny, nyaw)).astype(np.float32)
    values[values < 0.7] = 0.0
    x0, y0, res = rng.uniform(-1.5, 0.3), rng.uniform(-1.5, 0.3), rng.uniform(0.03, 0.15)
    per_m, n_angle = rng.uniform(5.0, 80.0), int(rng.integers(8, 100))
    table = polar_bound(values, x0, y0, res, per_m, n_angle)
    n = 20_000
    jx, jy = rng.integers(0, nx, n), rng.integers(0, ny, n)
    fx, fy = rng.random(n), rng.random(n)
    fx[: n // 4] = 0.0  # on a cell's lower edge or corner
    fy[n // 8 : n // 4] = 0.0
    px, py = x0 + (jx + fx) * res, y0 + (jy + fy) * res
    inside = (np.floor((px - x0) / res) == jx) & (np.floor((py - y0) / res) == jy)
    angle = rng.uniform(-4 * math.pi, 4 * math.pi, n)
    read = values[jx, jy, [wrap_bin(a, nyaw) for a in angle]]
    row = (np.hypot(px, py) * per_m).astype(int)
    k = np.floor((angle - np.arctan2(py, px)) / (2 * math.pi / n_angle)).astype(int) % n_angle
    assert (row < table.shape[0]).all()
    assert (table[row, k] >= read)[inside].all()
    assert (table > 0).mean() < 0.9 or values.mean() > 0.2  # a bound, not everything


@pytest.mark.parametrize(
    "poses, candidates, first", [(1, 1, False), (2, 1, True), (3, 1, False), (2, 4, True), (3, 5, False), (1, 8, True)]
)
def test_skipping_by_the_polar_bound_changes_no_result(poses, candidates, first):
    """Cells where some pose of a member reads at most the threshold at every base yaw by the polar
    bound are left unread: on random sparse slices the values and yaws equal the kernel's without the
    bound bit for bit, with and without a threshold, one-member and many-member groups."""
    rng = np.random.default_rng(poses * 100 + candidates)
    slices = rng.random((poses, 12, 14, 8)).astype(np.float32)
    slices[slices < 0.75] = 0.0
    slices = np.round(slices * 8) / 8
    tcp = rng.uniform(-0.3, 0.3, (2, 3 * poses))
    tcp_yaw = rng.uniform(-math.pi, math.pi, (3 * candidates * poses))
    yaws = base_yaws(36)
    cells = np.sort(rng.choice(16 * 15, 180, replace=False)).astype(np.int64)
    masks = rng.integers(0, 2**36, (180, 1)).astype(np.uint64)
    above = 0.75 if first else 0.0
    bound = np.ascontiguousarray(slices[0].max(axis=2))
    nobits = np.zeros((0, 0, 0), np.uint64)
    args = (slices, nobits, bound, [poses] * 3, [candidates] * 3, tcp, tcp_yaw, yaws, cells, masks, above, first)
    plain, skipping = run_kernel(*args), run_kernel(*args, polar=True)
    assert np.array_equal(plain[0], skipping[0]) and np.array_equal(plain[1], skipping[1])
    assert (plain[0] > above).sum() > 10 and (plain[0][:, cells // 15, cells % 15] == 0).sum() > 10
