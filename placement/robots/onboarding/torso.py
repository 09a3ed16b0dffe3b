"""Where ``robots init`` holds the joints that carry the arms: the torso above them and wheeled legs below
the root, in upright postures scored by what the arms serve of a table.

Postures (:func:`family_grid`): a prismatic joint (a lift) is tried at :data:`TORSO_STEPS` values over its
range. Revolute joints are grouped by parallel axes (at the reference configuration); in a group of
several (a torso of hip, knee and ankle pitch joints) all but the last are tried at :data:`PITCH_STEPS`
angles within +-:data:`PITCH_LIMIT` and the last cancels their sum, so the rotations compose to the
identity and the chest (or a wheel's mount) stays parallel to the root; a lone revolute joint is held
at 0 (mid-range when 0 is outside its limits). Legs that end in a wheel (:func:`wheeled_legs`) all take
the same posture about the same world axes, so every wheel stands on the floor.

Score (:func:`tune`): postures whose top-down bands (as ``robots check`` computes them) span
:data:`TABLE_BAND` come first, if any; then the 5 cm cells at :data:`TABLE_BAND` above the floor (the lowest point of the
robot's collision shapes and frames) that the arms' top-down grasps cover, summed over the arms; the
postures within 2 % of the best are tie-broken by the smallest change from the reference (mid-range for
lifts, 0 for revolute joints).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from placement.robots.chain import PRISMATIC, ancestors, extract_chain
from placement.robots.model_cache import frame_id
from placement.robots.onboarding.base import shape_corners
from placement.robots.onboarding.reach import QUANTILE, approach_mask, chain_fk, sample_configs, table_cells
from placement.robots.onboarding.tree import named_like

if TYPE_CHECKING:
    from placement.robots.onboarding.tcp import TCP

#: Heights [m] of a table top and a pre-grasp 10-15 cm above it: what the torso is tuned for.
TABLE_BAND = (0.70, 0.90)
TORSO_STEPS = 6
PITCH_STEPS = 5
#: Largest |angle| [rad] tried for a free joint of a parallel group (a deeper bend folds the body).
PITCH_LIMIT = 1.2
#: Most postures scored (grids beyond it are thinned).
MAX_POSTURES = 60
#: Joint samples per arm and posture.
TUNE_SAMPLES = 30_000
#: Joints named like these end a wheeled leg.
WHEEL_WORDS = ("wheel",)
#: Axes whose directions' cosine exceeds this are parallel.
PARALLEL = 0.999


def limits(model: pin.Model, jid: int) -> tuple[float, float, bool]:
    """(lower, upper [rad or m], continuous) of a 1-DoF joint."""
    jm = model.joints[jid]
    if jm.nq == 2:
        return -np.pi, np.pi, True
    return float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q]), False


def set_joint(model: pin.Model, q: np.ndarray, jid: int, value: float) -> None:
    jm = model.joints[jid]
    if jm.nq == 2:
        q[jm.idx_q : jm.idx_q + 2] = np.cos(value), np.sin(value)
    else:
        q[jm.idx_q] = value


def joint_axes(model: pin.Model, q: np.ndarray) -> dict[int, tuple[int, np.ndarray]]:
    """{joint id: (0 revolute | PRISMATIC, unit axis (3,) in the root frame)} of the 1-DoF joints at ``q``."""
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    out = {}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        if jm.nv != 1:
            continue
        col = pin.getJointJacobian(model, data, j, pin.WORLD)[:, jm.idx_v]
        lin, ang = col[:3], col[3:]
        if np.linalg.norm(ang) > 0.5:
            out[j] = (0, ang / np.linalg.norm(ang))
        elif np.linalg.norm(lin) > 0.5:
            out[j] = (PRISMATIC, lin / np.linalg.norm(lin))
    return out


@dataclass
class Family:
    """Joint chains that take one posture together (the torso; or every wheeled leg).

    Attributes:
        chains: [[joint ids, outwards from the root]], all with the template's pattern.
        what: "torso" or "legs" (for notes).
    """

    chains: list[list[int]]
    what: str


def wheeled_legs(model: pin.Model, actuated: set[int], taken: set[int]) -> list[list[int]]:
    """[[joint ids, root first]] of the legs ending in a wheel: the actuated joints above each joint named
    like a wheel, minus wheels, casters and ``taken`` (arm, hand, torso joints)."""
    legs = []
    for w in range(1, model.njoints):
        if not named_like(model.names[w], WHEEL_WORDS):
            continue
        leg = [
            j
            for j in reversed(ancestors(model, w)[1:])
            if j in actuated and j not in taken and not named_like(model.names[j], (*WHEEL_WORDS, "caster"))
        ]
        if leg and leg not in legs:
            legs.append(leg)
    return legs


def family_grid(model: pin.Model, q: np.ndarray, fam: Family) -> list[dict[int, float]]:
    """Upright postures {joint id: value [rad or m]} of ``fam`` (see the module docstring); chains whose
    pattern differs from the first one's keep ``q``'s values (they are left out)."""
    axes = joint_axes(model, q)
    template = fam.chains[0]
    chains = [c for c in fam.chains if len(c) == len(template) and all(c[k] in axes for k in range(len(c)))]
    chains = [c for c in chains if [axes[j][0] for j in c] == [axes[j][0] for j in template]]
    if not chains:
        return [{}]
    # positions grouped by parallel axes of the template; each chain's joint k turns by sign[c][k] * angle
    groups: list[list[int]] = []
    for k, j in enumerate(template):
        if axes[j][0] == PRISMATIC:
            groups.append([k])
            continue
        for g in groups:
            first = template[g[0]]
            if axes[first][0] != PRISMATIC and abs(axes[first][1] @ axes[j][1]) > PARALLEL:
                g.append(k)
                break
        else:
            groups.append([k])
    ref = {k: axes[template[g[0]]][1] for g in groups for k in g}
    sign = [[1.0 if axes[c[k]][1] @ ref[k] > 0 else -1.0 for k in range(len(c))] for c in chains]
    bounds = [
        (max(lo for lo, _ in b), min(hi for _, hi in b))
        for b in (
            [sorted((s[k] * limits(model, c[k])[0], s[k] * limits(model, c[k])[1])) for c, s in zip(chains, sign)]
            for k in range(len(template))
        )
    ]
    options: list[list[dict[int, float]]] = []  # per group: [{position: angle or value}]
    for g in groups:
        lo, hi = bounds[g[0]]
        if axes[template[g[0]]][0] == PRISMATIC:
            options.append([{g[0]: float(v)} for v in np.linspace(lo, hi, TORSO_STEPS)] if hi > lo else [{g[0]: lo}])
            continue
        if len(g) == 1:
            options.append([{g[0]: 0.0 if lo <= 0.0 <= hi else (lo + hi) / 2}])
            continue
        free = [
            np.unique(np.append(np.linspace(max(lo_, -PITCH_LIMIT), min(hi_, PITCH_LIMIT), PITCH_STEPS), 0.0))
            for lo_, hi_ in (bounds[k] for k in g[:-1])
        ]
        opts = []
        for values in itertools.product(*free):
            last = -float(sum(values))
            if max(bounds[g[-1]][0], -PITCH_LIMIT) <= last <= min(bounds[g[-1]][1], PITCH_LIMIT):
                opts.append({**{k: float(v) for k, v in zip(g[:-1], values)}, g[-1]: last})
        options.append(opts)
    out = []
    for combo in itertools.product(*options):
        angle = {k: v for part in combo for k, v in part.items()}
        out.append({c[k]: round(s[k] * angle[k], 4) + 0.0 for c, s in zip(chains, sign) for k in range(len(c))})
    return out


def change(model: pin.Model, posture: dict[int, float]) -> float:
    """How far ``posture`` is from the reference: sum of |value - mid-range| / range for prismatic joints
    and |angle| / pi for revolute ones."""
    total = 0.0
    for j, v in posture.items():
        lo, hi, _ = limits(model, j)
        if model.joints[j].shortname().replace("JointModel", "").startswith("P"):
            total += abs(v - (lo + hi) / 2) / max(hi - lo, 1e-9)
        else:
            total += abs(v) / np.pi
    return total


def lowest_point(
    model: pin.Model, data: pin.Data, geom: pin.GeometryModel | None, q: np.ndarray, skip: set[int]
) -> float:
    """Lowest z [m] in the root frame at ``q`` of the frame origins and the bounding-box corners of the
    collision shapes (``geom``, a pinocchio GeometryModel or None) not on the joints ``skip`` (the arms)."""
    pin.framesForwardKinematics(model, data, q)
    low = min(float(data.oMf[i].translation[2]) for i, f in enumerate(model.frames) if f.parentJoint not in skip)
    if geom is None:
        return low
    for _, corners in shape_corners(model, geom, q, skip):
        if np.all(np.isfinite(corners)):
            low = min(low, float(corners[:, 2].min()))
    return low


def words_of(model: pin.Model, posture: dict[int, float]) -> str:
    """'torso_1 0.4 rad, lift 0.25 m' for a posture."""
    unit: Callable[[int], str] = lambda j: "m" if joint_axes_kind(model, j) == PRISMATIC else "rad"  # noqa: E731
    return ", ".join(f"{model.names[j]} {v:g} {unit(j)}" for j, v in posture.items())


def joint_axes_kind(model: pin.Model, jid: int) -> int:
    """PRISMATIC for a prismatic joint, else 0 (from the joint model's name)."""
    short = model.joints[jid].shortname().replace("JointModel", "")
    return PRISMATIC if short.startswith("P") else 0


def score(
    model: pin.Model,
    q: np.ndarray,
    arms: list[list[int]],
    tcps: list[TCP],
    root_frame: int,
    floor: float,
    seed: int = 0,
    samples: int = TUNE_SAMPLES,
) -> tuple[bool, int]:
    """(whether every arm's top-down band, :data:`~.reach.QUANTILE` to 1 - it, spans :data:`TABLE_BAND`;
    5 cm cells at :data:`TABLE_BAND` above ``floor`` [m, root frame] that the arms' (joint id chains
    ``arms`` with TCPs ``tcps``) top-down grasps cover at ``q``)."""
    spans = True
    data = model.createData()
    base_T = np.eye(4)
    base_T[2, 3] = -floor
    total = 0
    for k, (chain, tcp) in enumerate(zip(arms, tcps)):
        qc = q.copy()
        for jid in chain:
            set_joint(model, qc, jid, 0.0)
        ch = extract_chain(
            model, qc, root_frame, chain, frame_id(model, tcp.tip_frame), tcp.offset, ("init", str(k)), data
        )
        lower = np.array([limits(model, j)[0] for j in chain])
        upper = np.array([limits(model, j)[1] for j in chain])
        T = chain_fk(ch, sample_configs(lower, upper, samples, seed + k), base_T)
        total += table_cells(T, *TABLE_BAND)
        z = T[approach_mask(T, "down"), 2, 3]
        spans = spans and len(z) > 0 and bool(np.quantile(z, QUANTILE) <= TABLE_BAND[0])
        spans = spans and bool(np.quantile(z, 1 - QUANTILE) >= TABLE_BAND[1])
    return spans, total


def tune(
    model: pin.Model,
    q: np.ndarray,
    families: list[Family],
    arms: list[list[int]],
    tcps: list[TCP],
    geom: pin.GeometryModel | None,
    skip: set[int],
) -> tuple[dict[str, float], np.ndarray, list[str]]:
    """(held {joint name: value}, the configuration with them set, notes) for the joint ``families``
    (torso, wheeled legs): see the module docstring. ``skip``: arm and hand joints (not the floor)."""
    grids = [family_grid(model, q, f) for f in families]
    postures = [{j: v for part in combo for j, v in part.items()} for combo in itertools.product(*grids)]
    if len(postures) > MAX_POSTURES:  # thin evenly, keeping the reference-nearest one
        keep = set(np.linspace(0, len(postures) - 1, MAX_POSTURES).round().astype(int))
        keep.add(min(range(len(postures)), key=lambda i: change(model, postures[i])))
        postures = [p for i, p in enumerate(postures) if i in keep]
    root = next(i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY)
    data = model.createData()
    samples = TUNE_SAMPLES if len(postures) <= TORSO_STEPS else max(8_000, TUNE_SAMPLES * TORSO_STEPS // len(postures))
    scored = []
    for posture in postures:
        qc = q.copy()
        for j, v in posture.items():
            set_joint(model, qc, j, v)
        floor = lowest_point(model, data, geom, qc, skip)
        spans, cells = score(model, qc, arms, tcps, root, floor, samples=samples)
        scored.append((posture, cells, qc, spans))
    if any(t[3] for t in scored):  # bands that hold a table and its pre-grasp come first (robots check's test)
        scored = [t for t in scored if t[3]]
    best = max(s for _, s, _, _ in scored)
    posture, value, qbest, _ = min((t for t in scored if t[1] >= 0.98 * best), key=lambda t: change(model, t[0]))
    held = {model.names[j]: v for j, v in posture.items()}
    notes = []
    for fam, grid in zip(families, grids):
        joints = {j for c in fam.chains for j in c}
        mine = {j: v for j, v in posture.items() if j in joints}
        if not mine:
            continue
        if len(grid) == 1:
            notes.append(f"{fam.what} held at {words_of(model, mine)} (revolute joints at 0: upright)")
            continue
        parallel = any(joint_axes_kind(model, j) != PRISMATIC and v != 0.0 for j, v in mine.items())
        how = (
            "upright (the rotations about parallel axes sum to 0, so the "
            + ("chest stays parallel to the root" if fam.what == "torso" else "wheels stand upright")
            + ")"
            if parallel or any(joint_axes_kind(model, j) != PRISMATIC for j in mine)
            else "over the joints' ranges"
        )
        notes.append(
            f"{fam.what} held at {words_of(model, mine)}: of {len(grid)} postures {how}, the one whose top-down "
            f"grasps cover the most 5 cm cells {TABLE_BAND[0]}-{TABLE_BAND[1]} m above the floor"
        )
    if len(posture) == 1:  # a lift: the cells of every value tried
        tried = ", ".join(f"{next(iter(p.values())):.3g}: {s}" for p, s, _, _ in scored)
        notes.append(f"cells per value: {tried}")
    else:
        scores = sorted(s for _, s, _, _ in scored)
        notes.append(
            f"cells covered: {value} (the best of {len(scored)} postures {best}, median {scores[len(scores) // 2]})"
        )
    if best == 0:
        notes.append("no held posture gives top-down grasps at table height")
    return held, qbest, notes
