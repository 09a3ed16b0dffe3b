"""The isotropy kernels underneath the extended manipulability: eigenvalue extremes, batched
octant proofs and bounds, the generated octant kernels, row penalties (against numpy references)."""

from __future__ import annotations

import numpy as np
import pytest
from support.manipulability import kernel_inputs, reference_jacobian, reference_measure, reference_penalties
from support.robots import random_configs

import placement


def test_sym_eig_extremes_matches_lapack():
    """Tridiagonal QL extremes against LAPACK on well- and ill-conditioned 6x6 Gram matrices."""
    from placement.kernels.manipulability import sym_eig_extremes

    rng = np.random.default_rng(11)
    for i in range(500):
        X = rng.normal(size=(6, 7)) * rng.uniform(1e-3, 1.0, size=(6, 1))
        if i % 3 == 0:
            X[:, rng.integers(7)] *= 1e-6
        A = X @ X.T
        w = np.linalg.eigvalsh(A)
        lmin, lmax = sym_eig_extremes(A.copy(), np.empty((2, 6)))
        scale = np.abs(A).max()
        assert abs(lmin - w[0]) <= 1e-13 * scale
        assert abs(lmax - w[-1]) <= 1e-13 * scale


@pytest.mark.parametrize("robot_name, arm_name", [("pr2", "right"), ("armar6", "right")])
def test_batched_kernel_proves_or_matches(robot_name, arm_name, request):
    """isotropy_batched: -1 exactly when the value is <= threshold, else the direct kernel's value bitwise.

    Thresholds cover 0 (empty cell), typical cell values, tiny values (where the
    proofs' margins grow) and configurations at joint limits (zero penalties).
    """
    from placement.kernels import manipulability as km
    from placement.kernels.isotropy import isotropy_batched

    robot = request.getfixturevalue(robot_name)
    arm = robot.arm(arm_name)
    rng = np.random.default_rng(12)
    Q = random_configs(arm, 600, rng)
    limited = ~arm.continuous.astype(bool)
    at_limit = rng.random(Q.shape) < 0.1
    Q[:, limited] = np.where(at_limit[:, limited], arm.upper[limited], Q[:, limited])
    J, (plo, phi, P, G, A, B, Ag, W, de) = kernel_inputs(arm, Q)
    ones = np.ones((6, 2))
    cont = arm.continuous.astype(bool)
    thresholds = np.random.default_rng(13).choice([-1.0, 0.0, 1e-5, 3e-4, 0.01, 0.03, 0.06, 0.1, 0.2], size=len(Q))
    proven = exact_count = 0
    for q, j, t in zip(Q, J, thresholds):
        km.joint_penalties(q, arm.lower, arm.upper, cont, plo, phi)
        exact = km.extended_manipulability(j, plo, phi, ones, km.ISOTROPY, -1.0, P, G, A, de)
        got = isotropy_batched(j, plo, phi, ones, t, P, G, Ag, W, A, B, de)
        if got < 0:
            assert exact <= t
            proven += 1
        else:
            assert exact > t and got == exact
            exact_count += 1
    assert proven > 50 and exact_count > 50  # the thresholds exercise both outcomes


@pytest.mark.slow
def test_octant_bounds_against_numpy():
    """The vectorised 64-octant kernels: rho <= lambda_max, mu >= lambda_min, pd_flags = eigvalsh > 0."""
    from placement.kernels import manipulability as km
    from placement.kernels import octants as ko
    from placement.kernels import octants_refine as kr

    rng = np.random.default_rng(5)
    for _ in range(30):
        J = rng.normal(size=(6, 7)) * rng.uniform(0.05, 1.0, size=(6, 1))
        plo, phi = rng.uniform(0.2, 1.0, 7), rng.uniform(0.2, 1.0, 7)
        P, G = np.empty((6, 7, 2)), np.empty((6, 6, 2, 2))
        km.gram_table(J, plo, phi, np.ones((6, 2)), P, G)
        Ag = np.empty((21, 64))
        ko.fill_grams(G, Ag)
        mats = np.empty((64, 6, 6))
        direct = np.empty((6, 6))
        for s in range(64):
            km.octant_gram(G, s, mats[s])
            km.octant_gram_direct(P, s, direct)
            assert np.array_equal(direct, mats[s])
        lam = np.linalg.eigvalsh(mats)
        rows = [(r, c) for r in range(6) for c in range(r + 1)]
        assert np.array_equal(Ag, np.array([mats[:, r, c] for r, c in rows]))
        rho, mu, flags, tr = np.empty(64), np.empty(64), np.empty(64), np.empty(64)
        ko.lambda_max_lower(Ag, rng.normal(size=6), rho)  # bounds hold from any start
        kr.lambda_min_upper(Ag, rng.normal(size=6), mu)
        assert np.all(rho <= lam[:, -1] * (1 + 1e-12))
        assert np.all(mu >= lam[:, 0] - 1e-13 * lam[:, -1])
        w, U = np.linalg.eigh(mats[0])  # and are tight from octant 0's eigenvectors, as used
        ko.lambda_max_lower(Ag, U[:, -1], rho)
        kr.lambda_min_upper(Ag, U[:, 0], mu)
        assert np.all(rho <= lam[:, -1] * (1 + 1e-12)) and np.median(rho / lam[:, -1]) > 0.9
        tight = np.empty(64)
        kr.lambda_max_tight(Ag, U[:, -1], tight)  # more steps: still a bound, and no looser
        assert np.all(tight <= lam[:, -1] * (1 + 1e-12)) and np.all(tight >= rho * (1 - 1e-12))
        assert np.all(mu >= lam[:, 0] - 1e-13 * lam[:, -1]) and np.median(mu / lam[:, 0]) < 2.0
        ko.traces(Ag, tr)
        assert np.allclose(tr, np.trace(mats, axis1=1, axis2=2))
        beta = -lam[:, 0] * rng.uniform(0.5, 1.5, 64)  # about half of the shifted matrices are definite
        ko.pd_flags(Ag, 1.0, beta, flags)
        expect = lam[:, 0] + beta > 0
        clear = np.abs(lam[:, 0] + beta) > 1e-9 * lam[:, -1]
        assert np.array_equal((flags > 0)[clear], expect[clear]) and 5 < expect.sum() < 59


def test_generated_octant_kernels_up_to_date():
    """placement/kernels/octants.py and octants_refine.py are exactly what tools/gen_octants.py writes."""
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "tools" / "gen_octants.py"
    spec = importlib.util.spec_from_file_location("gen_octants", path)
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    for path, text in gen.outputs().items():
        assert path.read_text() == text, f"{path.name} is stale: run python tools/gen_octants.py"


@pytest.mark.parametrize("robot,arm_name", [("pr2", "right"), ("armar6", "left")], indirect=["robot"])
def test_row_penalties_match_reference(robot, arm_name):
    """Per-row, per-sign factors (the self-distance penalty) against the numpy reference, both kernels."""
    from placement.kernels import manipulability as km
    from placement.kernels.isotropy import isotropy_batched

    arm = robot.arm(arm_name)
    rng = np.random.default_rng(31)
    Q = random_configs(arm, 60, rng)
    rf = np.ones((len(Q), 6, 2))
    rf[:, :3, :] = rng.uniform(0.2, 1.0, size=(len(Q), 3, 2))
    got = placement.extended_manipulability(robot, arm_name, Q, row_factors=rf)
    for q, g, f in zip(Q, got, rf):
        J = reference_jacobian(robot, arm_name, q)
        lo, hi = reference_penalties(q, arm.lower, arm.upper, arm.continuous)
        assert abs(g - reference_measure(J, lo, hi, "isotropy", f)) < 1e-9
    plain = placement.extended_manipulability(robot, arm_name, Q)
    assert np.any(got > plain + 1e-6) and np.any(got < plain - 1e-6)  # can raise or lower the index
    Jk, (plo, phi, P, G, A, B, Ag, W, de) = kernel_inputs(arm, Q)
    cont = arm.continuous.astype(bool)
    for q, j, f, exact in zip(Q, Jk, rf, got):
        km.joint_penalties(q, arm.lower, arm.upper, cont, plo, phi)
        assert isotropy_batched(j, plo, phi, f, -1.0, P, G, Ag, W, A, B, de) == exact
        t = exact * 1.01
        assert isotropy_batched(j, plo, phi, f, t, P, G, Ag, W, A, B, de) == -1.0
