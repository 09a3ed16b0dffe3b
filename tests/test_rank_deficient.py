"""The extended manipulability of arms that span fewer than 6 dimensions (kernels/subspace.py):
against numpy SVDs of the penalised octant Jacobians, rank 6 unchanged bit for bit, the generic
rank of real arms, and a map of the telescoping test robot."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from support.manipulability import SIGNS, kernel_inputs, reference_jacobian, reference_penalties
from support.robots import random_configs
from support.telescoping import REACH_X, telescoping_robot

import placement
from placement.errors import MapError, PlacementError
from placement.kernels.isotropy import isotropy_batched
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.manipulability import ISOTROPY, VOLUME, extended_manipulability, joint_penalties
from placement.kernels.sampling import configs_at
from placement.kernels.subspace import subspace_manipulability
from placement.kinematics.manipulability import arm_rank
from placement.maps.build import build_map, provable_grid
from placement.maps.opening import open_map
from placement.maps.rmap import save_maps

INDEXES = {"isotropy": ISOTROPY, "volume": VOLUME}
SO101 = {
    "name": "so101",
    "urdf": "package://example-robot-data/robots/so_arm_description/urdf/so101.urdf",
    "base_frame": "base_link",
    "footprint_radius": 0.2,
    "v_max": 0.3,
    "omega_max": 1.0,
    "arms": {
        "arm": {
            "joints": ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"],
            "tip_frame": "gripper_frame_link",
        }
    },
}


def reference_rank_measure(J, pen_lo, pen_hi, index: str, rank: int, rowfac=None) -> float:
    """min over the 64 octants of sigma_r/sigma_1 or sigma_1 ... sigma_r of J_s (numpy SVD), r = rank."""
    rowfac = np.ones((6, 2)) if rowfac is None else rowfac
    values = []
    for s in SIGNS:
        towards_hi = (s[:, None] >= 0) != (J < 0)
        Js = J * np.where(towards_hi, pen_hi, pen_lo) * np.where(s >= 0, rowfac[:, 0], rowfac[:, 1])[:, None]
        sv = np.linalg.svd(Js, compute_uv=False)  # descending; min(6, n) of them
        values.append(sv[rank - 1] / sv[0] if index == "isotropy" else float(np.prod(sv[:rank])))
    return min(values)


def random_rank_deficient(rng, n: int, rank: int) -> np.ndarray:
    """A (6, n) matrix of rank ``rank`` with entries of order 0.1 .. 1 (a Jacobian's scale)."""
    return rng.normal(size=(6, rank)) @ rng.normal(size=(rank, n)) * rng.uniform(0.1, 1.0)


def random_penalties(rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Per joint one side penalised by a factor from 1e-6 .. 1 (log-uniform), the other 1."""
    f = 10.0 ** rng.uniform(-6, 0, n)
    lower_side = rng.random(n) < 0.5
    return np.where(lower_side, f, 1.0), np.where(lower_side, 1.0, f)


def kernel_value(J, plo, phi, index: str, rank: int, rowfac=None, threshold: float = -1.0) -> float:
    n = J.shape[1]
    P, G, A, de = np.empty((6, n, 2)), np.empty((6, 6, 2, 2)), np.empty((6, 6)), np.empty((2, 6))
    rf = np.ones((6, 2)) if rowfac is None else rowfac
    return subspace_manipulability(J, plo, phi, rf, INDEXES[index], rank, threshold, P, G, A, de)


@pytest.mark.parametrize("index", ["isotropy", "volume"])
@pytest.mark.parametrize("n", [8, 5])
def test_kernel_matches_numpy_svd_on_random_rank5_jacobians(n, index):
    """6 x 8 and 6 x 5 Jacobians of rank 5, penalties from 1e-6 to 1, some with row factors:
    isotropy to 1e-9 absolute, volume to 1e-9 relative (as the full-rank kernels)."""
    rng = np.random.default_rng(7 + n)
    for k in range(60):
        J = random_rank_deficient(rng, n, 5)
        plo, phi = random_penalties(rng, n) if k % 3 else (np.ones(n), np.ones(n))
        rowfac = rng.uniform(0.3, 1.0, (6, 2)) if k % 4 == 1 else None
        got = kernel_value(J, plo, phi, index, 5, rowfac)
        want = reference_rank_measure(J, plo, phi, index, 5, rowfac)
        assert want > 0  # the rank-6 measure of these is 0 (or rounding)
        if index == "isotropy":
            assert abs(got - want) <= 1e-9, (k, got, want)
        else:
            assert abs(got - want) <= 1e-9 * want, (k, got, want)


def test_kernel_ranks_below_five_and_thresholds():
    """Any rank 1 .. 5 on a matrix of that rank; a threshold above the value gives -1, below it the value."""
    rng = np.random.default_rng(3)
    for rank in (1, 2, 3, 4, 5):
        J = random_rank_deficient(rng, 7, rank)
        plo, phi = random_penalties(rng, 7)
        want = reference_rank_measure(J, plo, phi, "isotropy", rank)
        assert kernel_value(J, plo, phi, "isotropy", rank) == pytest.approx(want, abs=1e-9)
        assert kernel_value(J, plo, phi, "isotropy", rank, threshold=want * 1.01) == -1.0
        assert kernel_value(J, plo, phi, "isotropy", rank, threshold=want * 0.99) == pytest.approx(want, abs=1e-9)


def test_rank6_is_todays_measure_bit_for_bit(pr2):
    """On the PR2 (rank 6) the subspace kernel, the public API and the batched isotropy agree bitwise
    with the unchanged full-rank kernel."""
    assert arm_rank(pr2, "right") == arm_rank(pr2, "left") == 6
    arm = pr2.arm("right")
    Q = random_configs(arm, 50, np.random.default_rng(11))
    Q[:10, 1] = arm.lower[1] + 1e-7  # near a limit: the refined octants too
    J, (plo, phi, P, G, A, B, Ag, W, de) = kernel_inputs(arm, Q)
    ones = np.ones((6, 2))
    cont = arm.continuous.astype(np.bool_)
    for index in (ISOTROPY, VOLUME):
        public = placement.extended_manipulability(pr2, "right", Q, index=("isotropy", "volume")[index])
        for i, q in enumerate(Q):
            joint_penalties(q, arm.lower, arm.upper, cont, plo, phi)
            today = extended_manipulability(J[i].copy(), plo, phi, ones, index, -1.0, P, G, A, de)
            sub = subspace_manipulability(J[i].copy(), plo, phi, ones, index, 6, -1.0, P, G, A, de)
            assert sub == today and public[i] == today
            if index == ISOTROPY:
                assert isotropy_batched(J[i].copy(), plo, phi, ones, -1.0, P, G, Ag, W, A, B, de) == today


def test_generic_rank_of_real_arms(tmp_path):
    """The telescoping arm (8 joints) and the 5-joint SO-101 span 5 dimensions; their values are > 0."""
    tel = telescoping_robot(tmp_path / "tel")
    assert tel.arm("arm").dof == 8 and arm_rank(tel, "arm") == 5
    so = tmp_path / "so101.yaml"
    so.write_text(yaml.safe_dump(SO101))
    so101 = placement.load_robot(so)
    assert so101.arm("arm").dof == 5 and arm_rank(so101, "arm") == 5
    for robot in (tel, so101):
        Q = random_configs(robot.arm("arm"), 20, np.random.default_rng(5))
        assert np.all(placement.extended_manipulability(robot, "arm", Q) > 1e-6)
        # the full-rank measure of the same arm is 0 up to rounding: the reason for the subspace
        assert np.all(placement.extended_manipulability(robot, "arm", Q, rank=6) < 1e-12)


@pytest.mark.parametrize("index", ["isotropy", "volume"])
def test_telescoping_arm_against_pinocchio_reference(tmp_path, index):
    """The public API on the telescoping arm against pinocchio's Jacobian and numpy SVDs, near limits too."""
    robot = telescoping_robot(tmp_path)
    arm = robot.arm("arm")
    rng = np.random.default_rng(2)
    Q = random_configs(arm, 30, rng)
    Q[:8, 1:5] = arm.lower[1:5] + 1e-6  # telescope retracted to its stops
    got = placement.extended_manipulability(robot, "arm", Q, index=index)
    for q, g in zip(Q, got):
        J = reference_jacobian(robot, "arm", q)
        assert np.linalg.matrix_rank(J, tol=1e-9 * np.linalg.norm(J, 2)) == 5
        want = reference_rank_measure(J, *reference_penalties(q, arm.lower, arm.upper, arm.continuous), index, 5)
        if index == "isotropy":
            assert abs(g - want) <= 1e-9
        else:
            assert abs(g - want) <= 1e-9 * want


def test_rank_argument_is_checked(pr2):
    with pytest.raises(PlacementError, match="rank must be a whole number from 1 to 6"):
        placement.extended_manipulability(pr2, "right", np.zeros(7), rank=7)


@pytest.mark.slow
def test_telescoping_map(tmp_path):
    """A small map of the telescoping arm: values > 0 where it reaches, in (0, 1]; rank 5 recorded;
    the grid about the arm's reach, not the link-length cube; a map that says rank 6 does not open."""
    robot = telescoping_robot(tmp_path / "robot")
    built = build_map(robot, "arm", samples=50_000, resolution=0.1, bins=(8, 5, 8), progress=False)
    m = built.meta
    assert m["measure"]["rank"] == 5 and m["grid_bound"] == "sampled reach"
    values = built.values
    reached = values[values > 0]
    assert reached.size > 5_000 and reached.max() <= 1.0 and np.median(reached) > 1e-3
    # the grid: x about the forward reach (plus margins), y a fraction of it, far below the cube
    shape = m["grid"]["shape"]
    assert shape[0] * 0.1 <= REACH_X + 0.5 and shape[1] * 0.1 <= 0.9
    assert values.size * 20 < provable_grid(robot, "arm", 0.1, (8, 5, 8)).size
    # where the build's own samples went, the map holds at least their (positive) value
    arm = robot.arm("arm")
    ch = arm.chain
    Q = configs_at(np.uint64(0), np.arange(1000, dtype=np.int64), arm.lower, arm.upper)
    T, _ = fk_jacobian_batch(Q, ch.link_T, ch.axis, ch.kind, ch.tip_T)
    cells = built.grid.index(T)
    assert np.all(cells >= 0)
    mine = placement.extended_manipulability(robot, "arm", Q).astype(np.float32)
    assert np.all(mine > 0) and np.all(values.reshape(-1)[cells] >= mine)
    out = tmp_path / "map"
    save_maps(out, robot, {"arm": built})
    assert open_map(out, "arm", robot).rank == 5


def test_rank_mismatch_is_an_error(tmp_path):
    """A map whose recorded rank differs from the arm's (e.g. built with the 6-D measure) does not open."""
    robot = telescoping_robot(tmp_path / "robot")
    built = build_map(robot, "arm", samples=2_000, resolution=0.2, bins=(4, 3, 4), progress=False)
    built.meta["measure"]["rank"] = 6
    save_maps(tmp_path / "map", robot, {"arm": built})
    with pytest.raises(MapError, match=r"holds the measure on 6 dimensions .* the arm spans 5; rebuild the map"):
        open_map(tmp_path / "map", "arm", robot)
