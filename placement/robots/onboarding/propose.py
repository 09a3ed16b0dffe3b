"""``placement robots init``: propose a commented preset for a robot from its URDF or xacro file.

:func:`propose` reads the description (:mod:`.init_urdf`), finds the arms, torso and hands
(:mod:`.init_tree`), the tip frames and TCP offsets (:mod:`.init_tcp`), the base frame and footprint
(:mod:`.init_base`), the self-collision pairs that are modelling artefacts (:mod:`.init_selfpairs`), and holds each torso joint where the arms serve the most of a table: prismatic
torso joints (lifts) are tried at :data:`TORSO_STEPS` values over their range and the one whose
top-down grasps cover the most 5 cm cells at :data:`TABLE_BAND` wins (ties: nearest mid-range);
revolute torso joints are held at 0 (or mid-range when 0 is outside their limits). They are held,
not made part of the arm chains: maps and the planner treat held joints as part of the robot.
:func:`render` writes the YAML with comments; the result loads with :func:`~placement.robots.load_robot`
unedited (:func:`propose` checks it).
"""

from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from placement.errors import PlacementError, RobotError
from placement.robots.chain import PRISMATIC, extract_chain
from placement.robots.onboarding.base import Base, find_base, load_collision, screen_collisions
from placement.robots.onboarding.reach import chain_fk, sample_configs, table_cells
from placement.robots.onboarding.selfpairs import ArtefactPair, artefact_pairs
from placement.robots.onboarding.tcp import TCP, deepen, hand_reach, infer_tcp
from placement.robots.onboarding.tree import analyse, arm_names, subtree
from placement.robots.onboarding.urdf import load_description
from placement.robots.preset import Robot, matrix_to_pose
from placement.robots.spec import MIN_ARM_JOINTS, PresetSpec, parse_preset, share_dir
from placement.validation import one_line, parse_yaml

#: Heights [m] of a table top and a pre-grasp 10-15 cm above it: what the torso is tuned for.
TABLE_BAND = (0.70, 0.90)
TORSO_STEPS = 6
#: Joint samples per arm and torso value when tuning the torso.
TUNE_SAMPLES = 30_000
V_MAX, OMEGA_MAX = 0.5, 1.0


@dataclass
class ArmProposal:
    name: str
    joints: list[str]
    tcp: TCP
    home: list[float]
    continuous: list[bool]


@dataclass
class Proposal:
    """A proposed preset: everything :func:`render` writes, and the plain-words notes and warnings."""

    source: Path
    name: str
    urdf: str
    base: Base
    fixed: dict[str, float]
    arms: list[ArmProposal]
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0
    ignore: list[ArtefactPair] = field(default_factory=list)

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "urdf": self.urdf,
            "base_frame": self.base.frame,
            "fixed_joints": self.fixed,
            "footprint": None if self.base.footprint is None else self.base.footprint.tolist(),
            "footprint_radius": self.base.radius,
            "arms": {
                a.name: {
                    "joints": a.joints,
                    "tip_frame": a.tcp.tip_frame,
                    "tcp_offset": [round(v, 6) for v in matrix_to_pose(a.tcp.offset)],
                    "tcp_inferred": a.tcp.how,
                    "home": a.home,
                }
                for a in self.arms
            },
            "ignore_collisions": [{"links": list(p.links), "fraction": p.fraction, "arm": p.arm} for p in self.ignore],
            "notes": self.notes,
            "warnings": self.warnings,
            "seconds": round(self.seconds, 3),
        }


def urdf_reference(path: Path, out: str | Path | None) -> str:
    """How the preset names its URDF: ``package://example-robot-data/...`` inside that package, else a
    path relative to the preset file ``out``, else absolute."""
    path = path.resolve()
    try:
        return "package://" + str(path.relative_to(share_dir().resolve()))
    except (ValueError, Exception):  # outside the package, or the package is not installed
        pass
    if out is not None:
        return os.path.relpath(path, Path(out).resolve().parent)
    return str(path)


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


def tune_torso(model, q, torso, arms, tcps, base_id) -> tuple[dict[str, float], list[str]]:
    """({torso joint: held value}, notes): see the module docstring."""
    held, notes, lifts = {}, [], []
    for jid in torso:
        lo, hi, cont = limits(model, jid)
        kind = extract_kind(model, jid)
        if kind == PRISMATIC and np.isfinite(lo) and np.isfinite(hi) and hi > lo:
            lifts.append((jid, np.linspace(lo, hi, TORSO_STEPS)))
        else:
            v = 0.0 if cont or lo <= 0.0 <= hi else (lo + hi) / 2
            held[model.names[jid]] = round(float(v), 4)
            notes.append(f"{model.names[jid]} held at {v:g} (a revolute torso joint: upright)")
        set_joint(model, q, jid, held.get(model.names[jid], 0.0))
    if not lifts:
        return held, notes
    data = model.createData()
    scores = []
    for values in itertools.product(*(v for _, v in lifts)):
        qc = q.copy()
        for (jid, _), v in zip(lifts, values):
            set_joint(model, qc, jid, v)
        score = 0
        for k, (chain, tcp) in enumerate(zip(arms, tcps)):
            for jid in chain:
                set_joint(model, qc, jid, 0.0)
            ch = extract_chain(
                model, qc, base_id, chain, model.getFrameId(tcp.tip_frame), tcp.offset, ("init", str(k)), data
            )
            lower = np.array([limits(model, j)[0] for j in chain])
            upper = np.array([limits(model, j)[1] for j in chain])
            score += table_cells(chain_fk(ch, sample_configs(lower, upper, TUNE_SAMPLES, k)), *TABLE_BAND)
        scores.append((values, score))
    best = max(s for _, s in scores)
    mids = [(lo + hi) / 2 for _, (lo, hi) in ((j, (v[0], v[-1])) for j, v in lifts)]
    values = min((v for v, s in scores if s >= 0.98 * best), key=lambda v: sum(abs(a - b) for a, b in zip(v, mids)))
    for (jid, rng), v in zip(lifts, values):
        held[model.names[jid]] = round(float(v), 4)
        tried = ", ".join(f"{x:.3g}: {s}" for x, s in ((vv[0], s) for vv, s in scores)) if len(lifts) == 1 else ""
        notes.append(
            f"{model.names[jid]} held at {v:.3g} of {rng[0]:.3g} .. {rng[-1]:.3g}: the value whose top-down "
            f"grasps cover the most 5 cm cells {TABLE_BAND[0]}-{TABLE_BAND[1]} m high"
            + (f" (cells per value: {tried})" if tried else "")
        )
    if best == 0:
        notes.append("no torso value gives top-down grasps at table height")
    return held, notes


def extract_kind(model: pin.Model, jid: int) -> int:
    """0 for a revolute joint, 1 (PRISMATIC) for a prismatic one (from its motion subspace)."""
    return PRISMATIC if "P" in model.joints[jid].shortname().replace("JointModel", "")[:1] else 0


def propose(path: str | Path, out: str | Path | None = None) -> Proposal:
    """A preset for the URDF or xacro at ``path`` (``out``: where it will be written, for a relative
    ``urdf:``). Raises a one-line :class:`RobotError` for an unusable file or a robot without arms."""
    t0 = time.perf_counter()
    d = load_description(path)
    model = d.model
    q = pin.neutral(model)
    tree = analyse(model, d.mimic, q)
    if not tree.arms:
        found = "; ".join(f"{', '.join(n)}: {why}" for n, why in tree.rejected) or "no actuated joints"
        raise RobotError(
            f"{d.path}: no arm with >= {MIN_ARM_JOINTS} actuated joints found "
            f"(finger, mimic and leg joints excluded); chains: {found}"
        )
    moved = {j for c in tree.arms for j in c} | {j for h in tree.hand.values() for j in h}
    base = find_base(model, d.xml, d.path, q, moved)
    base_id = model.getFrameId(base.frame)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    tcps = [infer_tcp(model, data, c, tree.hand[c[-1]]) for c in tree.arms]
    geom, _ = load_collision(model, d.xml, d.path)
    if geom is not None:  # fingers reaching far beyond a palm-centred grasp frame: a deeper TCP
        for k, c in enumerate(tree.arms):
            tip = data.oMf[model.getFrameId(tcps[k].tip_frame)].homogeneous
            reach, link = hand_reach(model, q, geom, set(subtree(model, c[-1])), tip @ tcps[k].offset)
            tcps[k] = deepen(tcps[k], reach, link)
    names, side_notes = arm_names(model, tree.arms, [float(data.oMi[c[-1]].translation[1]) for c in tree.arms])
    fixed, torso_notes = tune_torso(model, q.copy(), tree.torso, tree.arms, tcps, base_id)
    arms = []
    for name, chain, tcp in zip(names, tree.arms, tcps):
        lim = [limits(model, j) for j in chain]
        home = [0.0 if c else round((lo + hi) / 2, 4) for lo, hi, c in lim]
        arms.append(ArmProposal(name, [model.names[j] for j in chain], tcp, home, [c for _, _, c in lim]))
    warnings = list(base.warnings)
    warnings += [f"arm '{a.name}': {a.tcp.how}" for a in arms if a.tcp.guessed]
    others = [n for names_, why in tree.rejected for n in names_]
    notes = base.notes + side_notes + torso_notes
    if others:
        notes.append(f"held at their neutral values (not arms): {', '.join(others)}")
    if not tree.torso:
        notes.append("no torso joints above the arms")
    warnings.append(
        f"v_max {V_MAX} m/s and omega_max {OMEGA_MAX} rad/s are defaults: a URDF does not carry the base's speed limits"
    )
    p = Proposal(
        d.path, model.name or d.path.stem.split(".")[0], urdf_reference(d.path, out), base, fixed, arms, notes, warnings
    )
    from placement.robots.onboarding.render import render

    robot = check_loads(render(p), d.path, out)  # a proposal that does not load is refused, never written
    if screen_collisions(d.xml, d.path)[1]:  # the collision check would load the shapes init left out
        p.warnings.append(
            "self-collision pairs not sampled (collision shapes left out, see above): check ignore_collisions yourself"
        )
    else:
        try:
            p.ignore = artefact_pairs(robot)
        except PlacementError as exc:  # e.g. a xacro: placement.collision reads plain URDF geometry only
            p.warnings.append(f"self-collision pairs not sampled ({exc}): check ignore_collisions yourself")
    if p.ignore:
        p.warnings.append(
            f"{len(p.ignore)} link pairs that collide in most random arm configurations are "
            "taken as modelling artefacts and never checked (ignore_collisions): confirm them"
        )
        check_loads(render(p), d.path, out)
    p.seconds = time.perf_counter() - t0
    return p


def check_loads(text: str, source: Path, out: str | Path | None) -> Robot:
    """Load the rendered preset as :func:`~placement.robots.load_robot` would; a proposal that does not
    load is refused (one :class:`RobotError` line saying what in the URDF it stumbled on), never written."""
    where = str(out) if out else f"preset proposed for {source}"
    origin = Path(out).resolve().parent if out else Path.cwd()
    try:
        spec: PresetSpec = parse_preset(parse_yaml(text, where, RobotError), origin, where)
        return Robot(spec)
    except PlacementError as exc:
        raise RobotError(
            one_line(f"{source}: the proposed preset would not load, so it is not written: {exc}")
        ) from None
