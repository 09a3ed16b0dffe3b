"""Map-free reachability pieces for tools/kitchen_torso.py: batched forward kinematics of an arm chain,
a rigorous reach bound and a reduced IK that ignores where the base stands.

* :class:`ReachBound`: by the triangle inequality, the last joint's origin W (a point fixed in the TCP
  frame) lies within ``length`` [m] of the second joint's origin, and that origin lies on an arc about
  the first joint's axis (its limits). A base pose from which W of a target pose is farther than that
  from the arc cannot reach it, whatever the other joints do: a pruning test that never rejects a
  reachable pose (``tests/test_kitchen_torso.py`` checks it against forward kinematics).
* :func:`floor_ik`: a base on the floor can move in x, y and turn about z, so a world TCP pose is
  reachable from SOME base only if a configuration puts the TCP at the pose's height with the same
  tilt (world up seen in the TCP frame). Damped least squares on that 4-vector from many seeds; the
  solutions also say where the base would stand (:func:`bases_of`), which orders the grid search.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from placement.robots.chain import Chain

#: DLS damping [m^2, rad^2] and largest joint step per iteration [rad], as the planner's IK uses.
DAMPING, MAX_STEP = 1e-3, 0.4


def _rotations(axis: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(S, 3, 3) rotations by ``q`` (S,) [rad] about the unit ``axis`` (3,) (Rodrigues)."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(q)[:, None, None], np.cos(q)[:, None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def chain_fk(chain: Chain, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint frames (S, n, 4, 4) (after each joint's motion) and TCP poses (S, 4, 4) in the base frame
    for configurations ``q`` (S, n) [rad or m]."""
    S, n = q.shape
    T = np.broadcast_to(np.eye(4), (S, 4, 4)).copy()
    frames = np.empty((S, n, 4, 4))
    for i in range(n):
        T = T @ chain.link_T[i]
        M = np.broadcast_to(np.eye(4), (S, 4, 4)).copy()
        if chain.kind[i] == 0:
            M[:, :3, :3] = _rotations(chain.axis[i], q[:, i])
        else:
            M[:, :3, 3] = q[:, i, None] * chain.axis[i]
        T = T @ M
        frames[:, i] = T
    return frames, T @ chain.tip_T


@dataclass(frozen=True)
class ReachBound:
    """W (``w_tcp`` (3,), in the TCP frame [m]) stays within ``length`` [m] of the second joint's origin,
    which turns about the first joint's ``axis`` (3,) through ``centre`` (3,) [m] (base frame) at
    ``radial`` (3,) [m] from it when the first joint is 0, over [``lo``, ``hi``] [rad] (``full``: any
    angle)."""

    centre: np.ndarray
    axis: np.ndarray
    radial: np.ndarray
    lo: float
    hi: float
    full: bool
    length: float
    w_tcp: np.ndarray

    @classmethod
    def of(cls, chain: Chain, lower: np.ndarray, upper: np.ndarray, continuous: np.ndarray) -> ReachBound:
        T0 = chain.link_T[0]
        axis = T0[:3, :3] @ chain.axis[0]
        o0, o1 = T0[:3, 3], (T0 @ chain.link_T[1])[:3, 3]
        radial = (o1 - o0) - ((o1 - o0) @ axis) * axis
        length = float(sum(np.linalg.norm(chain.link_T[i][:3, 3]) for i in range(2, len(chain.kind))))
        w_tcp = -chain.tip_T[:3, :3].T @ chain.tip_T[:3, 3]
        if chain.kind.any():  # a prismatic joint changes its segment's length: no bound
            length = math.inf
        full = bool(continuous[0]) or float(upper[0] - lower[0]) >= 2 * math.pi
        return cls(o0 + ((o1 - o0) @ axis) * axis, axis, radial, float(lower[0]), float(upper[0]), full, length, w_tcp)

    def distance(self, w: np.ndarray) -> np.ndarray:
        """(N,) least distance [m] from points ``w`` (N, 3) (base frame) to the second joint's arc."""
        d = w - self.centre
        along = d @ self.axis
        perp = d - along[:, None] * self.axis
        rho = float(np.linalg.norm(self.radial))
        if rho == 0.0:
            return np.linalg.norm(d, axis=1)
        r0 = self.radial / rho
        phi = np.arctan2(np.cross(r0, perp) @ self.axis, perp @ r0)  # where the arc should point
        if not self.full:
            # the nearest angle of [lo, hi] to phi (mod 2 pi): the distance grows with the angle between them
            best = np.clip(phi, self.lo, self.hi)
            for shift in (-2 * math.pi, 2 * math.pi):
                alt = np.clip(phi + shift, self.lo, self.hi)
                better = np.abs(alt - phi - shift) < np.abs(best - phi)
                best = np.where(better, alt - shift, best)
            phi_used = best
        else:
            phi_used = phi
        p = self.centre + rho * (np.cos(phi_used)[:, None] * r0 + np.sin(phi_used)[:, None] * np.cross(self.axis, r0))
        return np.linalg.norm(w - p, axis=1)

    def admits(self, poses: np.ndarray, bases: np.ndarray) -> np.ndarray:
        """(N,) bool: bases (N, 3) (x [m], y [m], yaw [rad]) from which no pose of ``poses`` (P, 4, 4)
        (world) is ruled out by the bound (1 mm of slack for rounding)."""
        ok = np.ones(len(bases), dtype=bool)
        c, s = np.cos(bases[:, 2]), np.sin(bases[:, 2])
        for pose in poses:
            w = pose[:3, :3] @ self.w_tcp + pose[:3, 3]
            dx, dy = w[0] - bases[:, 0], w[1] - bases[:, 1]
            local = np.stack([c * dx + s * dy, -s * dx + c * dy, np.full(len(bases), w[2])], axis=1)
            ok &= self.distance(local) <= self.length + 1e-3
        return ok


def floor_ik(
    chain: Chain,
    lower: np.ndarray,
    upper: np.ndarray,
    continuous: np.ndarray,
    pose: np.ndarray,
    seeds: np.ndarray,
    tol_m: float = 2e-3,
    tol_rad: float = 2e-2,
    iterations: int = 150,
    enough: int = 12,
) -> np.ndarray:
    """(M, n) configurations (of the ``seeds`` (S, n), after descent) whose TCP has the height and the
    tilt of the world ``pose`` (4, 4): height within ``tol_m`` [m], world up in the TCP frame within
    ``tol_rad`` [rad]. None found: no base on the floor reaches the pose (up to the search). Stops once
    ``enough`` seeds have converged."""
    z, u = float(pose[2, 3]), pose[2, :3].copy()
    q = np.clip(seeds.astype(float), lower, upper)
    cont = continuous.astype(bool)
    up = np.array([0.0, 0.0, 1.0])
    for _ in range(iterations):
        frames, tcp = chain_fk(chain, q)
        p, R = tcp[:, :3, 3], tcp[:, :3, :3]
        a = np.einsum("snij,nj->sni", frames[:, :, :3, :3], chain.axis)
        o = frames[:, :, :3, 3]
        revolute = chain.kind == 0
        jv = np.where(revolute[None, :, None], np.cross(a, p[:, None] - o), a)
        jw = np.where(revolute[None, :, None], a, 0.0)
        e = np.concatenate([p[:, 2:3] - z, R[:, 2, :] - u], axis=1)  # R^T up = the third row of R
        done = (np.abs(e[:, 0]) <= tol_m) & (np.linalg.norm(e[:, 1:], axis=1) <= tol_rad)
        if done.all() or done.sum() >= enough:
            break
        zw = np.cross(up, jw)  # d(R^T up) = R^T (up x w)
        J = np.concatenate([jv[:, None, :, 2], np.einsum("sji,snj->sin", R, zw)], axis=1)  # (S, 4, n)
        A = J @ np.swapaxes(J, 1, 2) + DAMPING * np.eye(4)
        dq = -np.einsum("sni,si->sn", np.swapaxes(J, 1, 2), np.linalg.solve(A, e[..., None])[..., 0])
        norm = np.linalg.norm(dq, axis=1, keepdims=True)
        dq *= np.minimum(1.0, MAX_STEP / np.maximum(norm, 1e-12))
        q = np.where(done[:, None], q, q + dq)
        q = np.where(cont, (q + math.pi) % (2 * math.pi) - math.pi, np.clip(q, lower, upper))
    _, tcp = chain_fk(chain, q)
    e = np.concatenate([tcp[:, 2:3, 3] - z, tcp[:, 2, :3] - u], axis=1)
    ok = (np.abs(e[:, 0]) <= tol_m) & (np.linalg.norm(e[:, 1:], axis=1) <= tol_rad)
    out: np.ndarray = q[ok]
    return out


def bases_of(chain: Chain, pose: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(M, 3) base poses (x [m], y [m], yaw [rad]) that put the TCP of configurations ``q`` (M, n) at
    the world ``pose`` (4, 4) (exactly when ``q`` came from :func:`floor_ik` with zero error)."""
    _, tcp = chain_fk(chain, q)
    B = pose @ np.linalg.inv(tcp)
    return np.stack([B[:, 0, 3], B[:, 1, 3], np.arctan2(B[:, 1, 0], B[:, 0, 0])], axis=1)
