"""The batched rank-r isotropy (kernels/subspace_batched.py) against the octant-by-octant kernel it
replaces in map builds (kernels/subspace.py, itself checked against numpy SVDs in
test_rank_deficient.py): the same value bit for bit without a threshold, and with one the same
decision (-1 exactly when the value is <= the threshold, else the same value), on random rank-deficient
Jacobians with penalties and on the Jacobians of real rank-5 arms; its inertia counts against numpy's eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest
from support.robots import random_configs
from support.telescoping import telescoping_robot
from test_rank_deficient import random_penalties, random_rank_deficient, reference_rank_measure

from placement.kernels.isotropy import W_ROWS
from placement.kernels.kinematics import fk_jacobian_batch
from placement.kernels.manipulability import ISOTROPY, gram_table, joint_penalties
from placement.kernels.octants import fill_grams
from placement.kernels.subspace import subspace_manipulability
from placement.kernels.subspace_batched import subspace_isotropy_batched
from placement.kernels.subspace_inertia import ERROR_FACTOR, inertia
from placement.kinematics.manipulability import ROTATION_SCALE


def scratch(n: int):
    return dict(
        P=np.empty((6, n, 2)),
        G=np.empty((6, 6, 2, 2)),
        Ag=np.empty((21, 64)),
        Rg=np.empty((21, 64)),
        W=np.empty((W_ROWS, 64)),
        A=np.empty((6, 6)),
        B=np.empty((6, 6)),
        S=np.empty((2, 6, 6)),
        C=np.empty((21, 21)),
        de=np.empty((2, 6)),
    )


def batched(J, plo, phi, rank, threshold, rowfac=None) -> float:
    w = scratch(J.shape[1])
    rf = np.ones((6, 2)) if rowfac is None else rowfac
    names = ("P", "G", "Ag", "Rg", "W", "A", "B", "S", "C", "de")
    return subspace_isotropy_batched(J, plo, phi, rf, rank, threshold, *(w[k] for k in names))


def plain(J, plo, phi, rank, threshold, rowfac=None) -> float:
    n = J.shape[1]
    rf = np.ones((6, 2)) if rowfac is None else rowfac
    P, G, A, de = np.empty((6, n, 2)), np.empty((6, 6, 2, 2)), np.empty((6, 6)), np.empty((2, 6))
    return subspace_manipulability(J, plo, phi, rf, ISOTROPY, rank, threshold, P, G, A, de)


def agree(J, plo, phi, rank, rng, rowfac=None):
    """Bitwise equal exact values; with thresholds around the value, the same decision and value."""
    exact = plain(J, plo, phi, rank, -1.0, rowfac)
    got = batched(J, plo, phi, rank, -1.0, rowfac)
    assert got == exact, (got, exact)
    for f in (0.0, 0.3, 0.9, 0.999, 0.9999999, 1.0, 1.0000001, 1.001, 1.5, 10.0, rng.uniform(0.5, 2.0)):
        t = exact * f
        want, have = plain(J, plo, phi, rank, t, rowfac), batched(J, plo, phi, rank, t, rowfac)
        assert have == want or (have == -1.0 and exact <= t * (1 + 1e-6)), (f, have, want)
    return exact


@pytest.mark.slow
@pytest.mark.parametrize("n", [5, 6, 8])
def test_random_rank5_jacobians(n):
    rng = np.random.default_rng(n)
    for k in range(150):
        J = random_rank_deficient(rng, n, 5)
        plo, phi = random_penalties(rng, n) if k % 3 else (np.ones(n), np.ones(n))
        rowfac = rng.uniform(0.2, 1.0, (6, 2)) if k % 5 == 0 else None
        exact = agree(J, plo, phi, 5, rng, rowfac)
        assert exact == pytest.approx(reference_rank_measure(J, plo, phi, "isotropy", 5, rowfac), abs=1e-9)


def test_ranks_below_five():
    rng = np.random.default_rng(7)
    for rank in (1, 2, 3, 4):
        for _ in range(30):
            J = random_rank_deficient(rng, 7, rank)
            plo, phi = random_penalties(rng, 7)
            agree(J, plo, phi, rank, rng)


@pytest.mark.parametrize("robot_name", ["telescope", "so101"])
def test_real_rank5_arms(tmp_path, robot_name):
    """Jacobians of the telescoping test robot and example-robot-data's SO-101 at random configurations,
    penalised as a map build does (joint limits), some near the limits."""
    from test_rank_deficient import SO101

    import placement

    if robot_name == "telescope":
        robot = telescoping_robot(tmp_path / "robot")
    else:
        import yaml

        preset = tmp_path / "so101.yaml"
        preset.write_text(yaml.safe_dump(SO101))
        robot = placement.load_robot(preset)
    a = robot.arm("arm")
    Q = random_configs(a, 300, np.random.default_rng(4))
    Q[::7] = np.clip(Q[::7], a.lower + 1e-4, a.upper - 1e-4)
    Q[1::7] = np.where(np.arange(a.dof) % 2, a.lower + 1e-3, Q[1::7])
    _, Js = fk_jacobian_batch(Q, a.chain.link_T, a.chain.axis, a.chain.kind, a.chain.tip_T)
    rng = np.random.default_rng(5)
    plo, phi = np.empty(a.dof), np.empty(a.dof)
    for q, J in zip(Q, Js):
        J = J.copy()
        J[3:] *= ROTATION_SCALE
        joint_penalties(q, a.lower, a.upper, a.continuous.astype(np.bool_), plo, phi)
        agree(J, plo, phi, 5, rng)


def octant_grams(J, plo, phi):
    """The 64 octant Gram matrices (64, 6, 6) of J straight from their definition, and their packing (21, 64)."""
    n = J.shape[1]
    P, G, Ag = np.empty((6, n, 2)), np.empty((6, 6, 2, 2)), np.empty((21, 64))
    gram_table(J, plo, phi, np.ones((6, 2)), P, G)
    fill_grams(G, Ag)
    Js = np.array([[P[r, :, (s >> r) & 1] for r in range(6)] for s in range(64)])
    return Js @ Js.transpose(0, 2, 1), Ag


def test_inertia_counts_against_numpy():
    """The negative pivots of A_s - c I are the eigenvalues below c wherever c is farther from every
    eigenvalue than the error bound; and the bound is a small multiple of lambda_1 there."""
    rng = np.random.default_rng(3)
    checked = 0
    for k in range(200):
        n = int(rng.integers(4, 9))
        J = random_rank_deficient(rng, n, int(rng.integers(1, 7)))
        plo, phi = random_penalties(rng, n) if k % 2 else (np.ones(n), np.ones(n))
        A, Ag = octant_grams(J, plo, phi)
        lam = np.linalg.eigvalsh(A)  # (64, 6), ascending
        # shifts at random eigenvalue ratios, at exact eigenvalues, and between two close ones
        c = lam[:, -1] * 10.0 ** rng.uniform(-8, 0.1, 64)
        c[::7] = lam[::7, int(rng.integers(0, 6))]
        neg, err = np.empty(64), np.empty(64)
        inertia(Ag, -c, neg, err)
        below = (lam < c[:, None]).sum(axis=1)
        clear = np.abs(lam - c[:, None]).min(axis=1) > ERROR_FACTOR * err
        assert np.array_equal(neg[clear], below[clear]), k
        checked += int(clear.sum())
    assert checked > 0.8 * 200 * 64


def test_witnesses_of_a_rank5_map_verify_with_the_recorded_rank(tmp_path):
    """verify_witnesses recomputes a telescoping arm's map bit for bit with the rank its metadata records
    (the batched kernel in the build, the same values in the check); told rank 6 instead, it finds the
    values differ (the full-rank measure of a rank-5 arm is ~0)."""
    import copy

    from placement.maps.build import build_map
    from placement.maps.witness import verify_witnesses

    robot = telescoping_robot(tmp_path / "robot")
    built = build_map(robot, "arm", samples=20_000, resolution=0.1, bins=(8, 5, 8), progress=False)
    assert built.meta["measure"]["rank"] == 5
    r = verify_witnesses(robot, built, sample=300, seed=0)
    assert r["cells_checked"] == 300 and r["mismatches"] == 0
    wrong = copy.copy(built)
    wrong.meta = copy.deepcopy(built.meta)
    wrong.meta["measure"]["rank"] = 6
    assert verify_witnesses(robot, wrong, sample=300, seed=0)["mismatches"] == 300


def test_inertia_module_is_generated():
    """placement/kernels/subspace_inertia.py is exactly what tools/gen_subspace_inertia.py writes."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "tools" / "gen_subspace_inertia.py"
    spec = importlib.util.spec_from_file_location("gen_subspace_inertia", path)
    assert spec is not None and spec.loader is not None
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.OUT.read_text() == gen.source(), "subspace_inertia.py is stale: run python tools/gen_subspace_inertia.py"
