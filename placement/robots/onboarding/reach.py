"""What an arm reaches before any map is built: bands of heights and distances for a given approach.

The arm's joints are sampled uniformly within their limits (a seeded generator), the canonical TCP is
placed by forward kinematics of the arm's :class:`~placement.robots.chain.Chain` (vectorised numpy),
and the samples whose approach axis (TCP z) lies within :data:`APPROACH_TOLERANCE` of the wanted
direction are kept:

- ``"down"``: a top-down grasp, TCP z along -z of the base frame;
- ``"horizontal"``: TCP z in the floor plane (a side grasp), pointing away from the base's vertical
  axis.

A :class:`Band` gives the heights z [m] above the base frame (the floor) and the horizontal distances
r [m] from the base frame's vertical axis of those samples beyond the base (the :data:`QUANTILE` and ``1 -
QUANTILE`` quantiles, so one lucky sample does not stretch the band), and a per-height profile in
slices of :data:`SLICE` [m]. The planner uses it to say why a pose is out of reach.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from placement.robots.chain import PRISMATIC, Chain
from placement.robots.footprint import inscribed_radius

if TYPE_CHECKING:
    from placement.robots.preset import Robot


#: Largest angle between the TCP's approach axis and the wanted direction [rad].
APPROACH_TOLERANCE = math.radians(15)
#: Lower/upper quantile of the band (the band holds 98 % of the matching samples).
QUANTILE = 0.01
#: Height slice of the profile [m].
SLICE = 0.05
#: Joint samples per band (a few hundred milliseconds for a 7-joint arm).
SAMPLES = 200_000
APPROACHES = ("down", "horizontal")


def rotations(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(m, 3, 3) rotations by ``angle`` (m,) [rad] about the unit ``axis`` (3,) (Rodrigues)."""
    x, y, z = axis
    K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return cast(np.ndarray, np.eye(3) + s * K + (1.0 - c) * (K @ K))


def chain_fk(chain: Chain, Q: np.ndarray, base_T: np.ndarray | None = None) -> np.ndarray:
    """(m, 4, 4) canonical TCP poses in the base frame for joint values ``Q`` (m, n) [rad or m].

    ``base_T`` (4, 4): an extra transform in front (e.g. a base pose in the world).
    """
    Q = np.atleast_2d(np.asarray(Q, dtype=float))
    m = len(Q)
    T = np.broadcast_to(np.eye(4) if base_T is None else base_T, (m, 4, 4)).copy()
    for i in range(len(chain.kind)):
        T = T @ chain.link_T[i]
        M = np.broadcast_to(np.eye(4), (m, 4, 4)).copy()
        if chain.kind[i] == PRISMATIC:
            M[:, :3, 3] = Q[:, i, None] * chain.axis[i]
        else:
            M[:, :3, :3] = rotations(chain.axis[i], Q[:, i])
        T = T @ M
    return cast(np.ndarray, T @ chain.tip_T)


def sample_configs(lower: np.ndarray, upper: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
    """(n, dof) joint values drawn uniformly within [lower, upper] by ``default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    return cast(np.ndarray, rng.uniform(lower, upper, size=(n, len(lower))))


def approach_mask(T: np.ndarray, approach: str, tolerance: float = APPROACH_TOLERANCE) -> np.ndarray:
    """(m,) bool: TCP poses ``T`` (m, 4, 4) whose approach axis (z) is within ``tolerance`` [rad] of
    ``approach`` ("down" or "horizontal", see the module docstring)."""
    z = T[:, :3, 2]
    if approach == "down":
        return -z[:, 2] >= math.cos(tolerance)
    if approach == "horizontal":
        radial = T[:, :2, 3]
        norm = np.linalg.norm(radial, axis=1)
        outward = np.einsum("ij,ij->i", z[:, :2], radial) > 0.5 * norm * np.linalg.norm(z[:, :2], axis=1)
        return cast(np.ndarray, (np.abs(z[:, 2]) <= math.sin(tolerance)) & outward)
    raise ValueError(f"approach must be one of {', '.join(APPROACHES)}, got {approach!r}")


@dataclass
class Band:
    """Heights and distances an arm reaches with one approach (see the module docstring).

    Attributes:
        arm: arm name.
        approach: "down" or "horizontal".
        z_min, z_max: band of TCP heights above the base frame [m] (NaN if nothing matched).
        r_min, r_max: band of horizontal distances from the base frame's vertical axis [m].
        samples: joint samples drawn; matched: how many had this approach.
        profile: per height slice [z_low, z_high) [m] with matches: {"z": [z_low, z_high], "r_min",
            "r_max" [m], "count"}.
        held: {joint: value [rad or m]} the robot's fixed joints while sampling.
    """

    arm: str
    approach: str
    z_min: float
    z_max: float
    r_min: float
    r_max: float
    samples: int
    matched: int
    profile: list[dict[str, Any]] = field(default_factory=list)
    held: dict[str, float] = field(default_factory=dict)

    @property
    def empty(self) -> bool:
        return self.matched == 0

    def contains_height(self, z: float) -> bool:
        """Whether height ``z`` [m] lies inside [z_min, z_max]."""
        return not self.empty and self.z_min <= z <= self.z_max

    def to_json(self) -> dict[str, Any]:
        num: Callable[[float], float | None] = lambda v: None if not math.isfinite(v) else round(float(v), 4)  # noqa: E731
        return {
            "arm": self.arm,
            "approach": self.approach,
            "z_min": num(self.z_min),
            "z_max": num(self.z_max),
            "r_min": num(self.r_min),
            "r_max": num(self.r_max),
            "samples": self.samples,
            "matched": self.matched,
            "profile": self.profile,
            "held": dict(self.held),
        }


def band_of(
    T: np.ndarray, approach: str, arm: str = "", held: dict[str, float] | None = None, min_distance: float = 0.0
) -> Band:
    """The :class:`Band` of the TCP poses ``T`` (m, 4, 4) [m] in the base frame that are at least
    ``min_distance`` [m] from the base frame's vertical axis."""
    keep = T[approach_mask(T, approach) & (np.hypot(T[:, 0, 3], T[:, 1, 3]) >= min_distance)]
    held = dict(held or {})
    if len(keep) == 0:
        nan = math.nan
        return Band(arm, approach, nan, nan, nan, nan, len(T), 0, [], held)
    z = keep[:, 2, 3]
    r = np.hypot(keep[:, 0, 3], keep[:, 1, 3])
    lo, hi = QUANTILE, 1.0 - QUANTILE
    profile = []
    idx = np.floor(z / SLICE).astype(np.int64)
    for k in np.unique(idx):
        rk = r[idx == k]
        profile.append(
            {
                "z": [round(float(k) * SLICE, 4), round(float(k + 1) * SLICE, 4)],
                "r_min": round(float(rk.min()), 4),
                "r_max": round(float(rk.max()), 4),
                "count": int(len(rk)),
            }
        )
    return Band(
        arm,
        approach,
        float(np.quantile(z, lo)),
        float(np.quantile(z, hi)),
        float(np.quantile(r, lo)),
        float(np.quantile(r, hi)),
        len(T),
        len(keep),
        profile,
        held,
    )


def arm_poses(robot: Robot, arm: str, samples: int = SAMPLES, seed: int = 0) -> np.ndarray:
    """(samples, 4, 4) TCP poses [m] of uniformly sampled configurations of ``arm``; continuous joints
    over [-pi, pi)."""
    a = robot.arm(arm)
    return chain_fk(a.chain, sample_configs(a.lower, a.upper, samples, seed))


def base_clearance(robot: Robot) -> float:
    """[m] the inscribed radius of the robot's footprint (its radius for a round base): a TCP nearer the
    base's vertical axis is above the base itself, not above anything beside it."""
    return robot.footprint_radius if robot.footprint is None else inscribed_radius(robot.footprint)


def reach_band(robot: Robot, arm: str, approach: str = "down", samples: int = SAMPLES, seed: int = 0) -> Band:
    """The band of heights and distances ``arm`` of ``robot`` reaches with ``approach`` ("down" or
    "horizontal") beyond the base (:func:`base_clearance`), with the robot's fixed joints as the preset
    holds them."""
    if approach not in APPROACHES:
        raise ValueError(f"approach must be one of {', '.join(APPROACHES)}, got {approach!r}")
    return band_of(arm_poses(robot, arm, samples, seed), approach, arm, robot.fixed_joints, base_clearance(robot))


def table_cells(T: np.ndarray, z_low: float, z_high: float, cell: float = SLICE) -> int:
    """Distinct (x, y) cells of edge ``cell`` [m] holding a top-down TCP pose of ``T`` (m, 4, 4) with a
    height in [z_low, z_high] [m]: how much of a table at that height the arm serves."""
    keep = T[approach_mask(T, "down")]
    keep = keep[(keep[:, 2, 3] >= z_low) & (keep[:, 2, 3] <= z_high)]
    if len(keep) == 0:
        return 0
    return len(np.unique(np.floor(keep[:, :2, 3] / cell).astype(np.int64), axis=0))
