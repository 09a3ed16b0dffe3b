"""Map witnesses: deterministic, stored and checked, regenerate the configuration behind every value."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
from click.testing import CliRunner

import placement
from placement import MapError
from placement.cli.main import cli
from placement.maps.witness import K, empty_value, verify_witnesses, witness_configs

SMALL = dict(resolution=0.1, bins=(10, 5, 10))
N = 30_000


@pytest.fixture(scope="module")
def completed(pr2):
    return placement.build_map(pr2, "right", samples=N, seed=3, progress=False, completion=True, **SMALL)


@pytest.fixture(scope="module")
def saved(tmp_path_factory, pr2, completed):
    return placement.save_maps(tmp_path_factory.mktemp("w") / "pr2", pr2, {"right": completed})


@pytest.mark.slow
def test_witness_marks_exactly_the_reached_cells(completed):
    empty = empty_value(completed.witness.dtype)
    assert completed.witness.dtype == np.uint32 and completed.witness.shape == completed.values.shape
    assert np.array_equal(completed.values > 0, completed.witness != empty)
    w = completed.witness[completed.witness != empty].astype(np.int64)
    assert w.max() < N * (1 + K)
    assert np.any(w >= N), "completion added no sample"


@pytest.mark.slow
def test_completion_adds_cells_and_is_block_independent(pr2, completed):
    plain = placement.build_map(pr2, "right", samples=N, seed=3, progress=False, **SMALL)
    c = completed.meta["completion"]
    assert c["cells_before"] == np.count_nonzero(plain.values) < np.count_nonzero(completed.values)
    assert c["cells_added"] == np.count_nonzero(completed.values) - c["cells_before"]
    # completion only raises values
    assert np.all(completed.values >= plain.values)
    other = placement.build_map(pr2, "right", samples=N, seed=3, progress=False, completion=True, block=4099, **SMALL)
    assert np.array_equal(other.values, completed.values) and np.array_equal(other.witness, completed.witness)


def test_ties_go_to_the_smallest_witness(pr2):
    """Two copies of the same configuration under different numbers: the smaller number wins."""
    from placement.kernels.sampling import reduce_max

    grid = np.zeros(4, dtype=np.float32)
    wit = np.full(4, empty_value(np.uint32), dtype=np.uint32)
    reduce_max(grid, wit, np.array([2, 2]), np.array([0.5, 0.5]), np.array([9, 4]))
    assert wit[2] == 4
    reduce_max(grid, wit, np.array([2]), np.array([0.5]), np.array([7]))
    assert wit[2] == 4 and grid[2] == np.float32(0.5)


def fk_pinocchio(robot, arm_name, q):
    """TCP pose (4, 4) in the base frame from pinocchio (independent of the numba kernels)."""
    arm = robot.arm(arm_name)
    model = pin.Model(robot.model)
    tip_id = model.getFrameId(arm.tip_frame)
    tip = model.frames[tip_id]
    tcp = model.addFrame(
        pin.Frame(
            "witness_tcp", tip.parentJoint, tip_id, tip.placement * pin.SE3(arm.tcp_offset), pin.FrameType.OP_FRAME
        )
    )
    data = model.createData()
    qf = robot.full_q(arm_name, q)
    pin.framesForwardKinematics(model, data, qf)
    base = data.oMf[model.getFrameId(robot.base_frame)]
    return (base.inverse() * data.oMf[tcp]).homogeneous


@pytest.mark.slow
def test_witness_q_lies_in_the_cell_of_the_pose(pr2, saved, completed):
    rmap = placement.open_map(saved, "right")
    g = rmap.grid
    rng = np.random.default_rng(0)
    w = completed.witness.reshape(-1)
    reached = np.flatnonzero(completed.values.reshape(-1) > 0)
    refined = reached[w[reached] >= N]
    cells = np.concatenate([rng.choice(reached, 20, replace=False), rng.choice(refined, 20, replace=False)])
    # a pose anywhere in the cell (not just the centre) finds the cell's witness
    from placement.maps.accuracy import poses_in_cells

    for cell, pose in zip(cells, poses_in_cells(g, cells, rng)):
        q = rmap.witness_q(pose)
        assert q is not None and q.shape == (7,)
        assert g.index(fk_pinocchio(pr2, "right", q))[0] == cell
    empty = np.flatnonzero(completed.values.reshape(-1) == 0)[:5]
    for pose in g.centre(empty):
        assert rmap.witness_q(pose) is None
    far = np.eye(4)
    far[:3, 3] = 50.0
    assert rmap.witness_q(far) is None


def test_witness_q_is_fast(saved):
    import time

    rmap = placement.open_map(saved, "right")
    pose = rmap.grid.centre(np.flatnonzero(rmap.values.reshape(-1) > 0)[:1])[0]
    rmap.witness_q(pose)
    t = time.perf_counter()
    for _ in range(200):
        rmap.witness_q(pose)
    assert (time.perf_counter() - t) / 200 < 2e-3  # tens of microseconds on a quiet machine


@pytest.mark.slow
def test_verify_recomputes_every_value_bitwise(pr2, completed):
    r = verify_witnesses(pr2, completed)
    assert r["mismatches"] == 0 and r["cells_checked"] == r["cells_reached"] == np.count_nonzero(completed.values)
    part = verify_witnesses(pr2, completed, sample=100, seed=1)
    assert part["cells_checked"] == 100 and part["mismatches"] == 0


@pytest.mark.slow
def test_verify_finds_a_changed_value_or_witness(pr2, completed):
    values, wit = completed.values.copy(), completed.witness.copy()
    cells = np.flatnonzero(values.reshape(-1) > 0)
    values.reshape(-1)[cells[10]] = np.nextafter(values.reshape(-1)[cells[10]], np.float32(1))
    a, b = wit.reshape(-1)[cells[20]], wit.reshape(-1)[cells[21]]
    wit.reshape(-1)[cells[20]], wit.reshape(-1)[cells[21]] = b, a
    r = verify_witnesses(pr2, placement.BuiltMap(values, completed.meta, wit))
    assert r["mismatches"] == 3
    assert {f["cell"] for f in r["first"]} == {int(cells[10]), int(cells[20]), int(cells[21])}


def test_witness_configs_rejects_empty_witness(pr2, completed):
    with pytest.raises(MapError, match="numbering"):
        witness_configs(pr2.arm("right"), completed.grid, 3, N, np.array([empty_value(np.uint32)]))


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["zarr", "hdf5"])
def test_cli_verify(tmp_path, pr2, completed, fmt):
    path = placement.save_maps(tmp_path / ("m.h5" if fmt == "hdf5" else "m"), pr2, {"right": completed}, fmt)
    res = CliRunner().invoke(cli, ["maps", "verify", str(path), "--json", "-q"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)["arms"]["right"]
    assert out["mismatches"] == 0 and out["cells_checked"] == np.count_nonzero(completed.values)
    res = CliRunner().invoke(cli, ["maps", "verify", str(path), "--samples", "50", "-q"])
    assert res.exit_code == 0 and "50 of" in res.output and "all equal" in res.output
    # a map whose stored value no longer follows from its witness
    bad = completed.values.copy()
    cell = np.flatnonzero(bad.reshape(-1) > 0)[5]
    bad.reshape(-1)[cell] *= 0.5
    path2 = placement.save_maps(
        tmp_path / ("b.h5" if fmt == "hdf5" else "b"),
        pr2,
        {"right": placement.BuiltMap(bad, completed.meta, completed.witness)},
        fmt,
    )
    res = CliRunner().invoke(cli, ["maps", "verify", str(path2), "-q"])
    assert res.exit_code == 1
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and "1 MISMATCH" in lines[0] and f"cell {cell}" in lines[0]


@pytest.mark.slow
def test_saved_witnesses_are_checked(tmp_path, pr2, completed):
    """A changed witness chunk on disk is a one-line MapError, like a changed value chunk."""
    path = placement.save_maps(tmp_path / "m.h5", pr2, {"right": completed}, "hdf5")
    import h5py

    with h5py.File(path, "r+") as fh:
        ds = fh["right.witness"]
        iz = int(np.nonzero(completed.values.any(axis=(0, 1, 3, 4, 5)))[0][0])
        chunk = ds[:, :, iz, :, 0, 0]
        chunk[0, 0, 0] ^= 1
        ds[:, :, iz, :, 0, 0] = chunk
    rmap = placement.open_map(path, "right")
    with pytest.raises(MapError, match="witness chunk"):
        _ = rmap.witness  # reading the property checks the chunk


def test_map_without_witnesses_cannot_be_saved(tmp_path, pr2, completed):
    with pytest.raises(MapError, match="witnesses"):
        placement.save_maps(tmp_path / "x", pr2, {"right": placement.BuiltMap(completed.values, completed.meta)})


@pytest.mark.slow
def test_completion_from_spec_and_cli(tmp_path):
    from placement.errors import PlacementError
    from placement.maps.buildspec import parse_build_spec

    assert parse_build_spec({"completion": True}).completion is True
    with pytest.raises(PlacementError, match="completion must be true or false"):
        parse_build_spec({"completion": "yes"}, "spec")
    out = tmp_path / "m"
    res = CliRunner().invoke(
        cli,
        [
            "maps",
            "build",
            "--robot",
            "pr2",
            "--arm",
            "right",
            "--samples",
            "2000",
            "--resolution",
            "0.2",
            "--bins",
            "4,3,4",
            "--completion",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert res.exit_code == 0, res.output
    meta = placement.open_map(out, "right").meta
    assert meta["witness"]["completion"] and meta["completion"]["cells_added"] > 0
    assert meta["filled_cells"] == meta["completion"]["cells_before"] + meta["completion"]["cells_added"]


def _neighbour_reference(cell, k, shape):
    """NEIGHBOURS[k] of flat ``cell`` by numpy's unravel/ravel (yaw and roll wrap; None outside)."""
    from placement.kernels.sampling import NEIGHBOURS

    idx = list(np.unravel_index(cell, shape))
    a, step = (int(v) for v in NEIGHBOURS[k])
    idx[a] += step
    if a in (3, 5):
        idx[a] %= shape[a]
    elif not 0 <= idx[a] < shape[a]:
        return -1
    return int(np.ravel_multi_index(idx, shape))


def _sources_reference(grid, witness, plain, shape):
    """completion_sources as its docstring says, in plain Python: for each source cell in order, each
    direction in order, the empty neighbour whose first plain-witness reached neighbour it is."""
    from placement.kernels.sampling import NEIGHBOURS

    def ok(c):
        return c >= 0 and grid[c] > 0 and witness[c] < plain

    out = []
    for c in range(grid.size):
        if not ok(c):
            continue
        for d in range(len(NEIGHBOURS)):
            t = _neighbour_reference(c, d, shape)
            if t >= 0 and grid[t] == 0:
                first = next(
                    (n for n in (_neighbour_reference(t, e, shape) for e in range(len(NEIGHBOURS))) if ok(n)), -1
                )
                if first == c:
                    out.append((int(witness[c]), d))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_completion_sources_equal_a_plain_reference(seed):
    """The parallel scan (fixed cell ranges, count then fill) gives the serial definition's candidates in
    its order, for random sparse grids of odd shapes (cells at every wrap and edge)."""
    from placement.kernels.sampling import completion_sources, neighbour_cell

    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 5, 6))
    n = int(np.prod(shape))
    for cell in rng.integers(0, n, 200):
        for k in range(12):
            assert neighbour_cell(int(cell), k, np.array(shape, np.int64)) == _neighbour_reference(int(cell), k, shape)
    grid = np.where(rng.random(n) < [0.05, 0.2, 0.5, 0.9][seed], rng.random(n) + 0.1, 0.0).astype(np.float32)
    plain = 1000
    witness = np.where(grid > 0, rng.integers(0, 2 * plain, n), 0).astype(np.int64)
    src, dirs = completion_sources(grid, witness, plain, np.array(shape, np.int64))
    assert list(zip(src.tolist(), dirs.tolist())) == _sources_reference(grid, witness, plain, shape)
