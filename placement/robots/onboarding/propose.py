"""``placement robots init``: propose a commented preset for a robot from its URDF or xacro file.

:func:`propose` reads the description (:mod:`.init_urdf`), finds the arms, torso and hands
(:mod:`.init_tree`), the tip frames and TCP offsets (:mod:`.init_tcp`), the base frame and footprint
(:mod:`.base`), the self-collision pairs that are modelling artefacts (:mod:`.selfpairs`), how many
pose directions each arm spans (:mod:`.rank`), and holds the torso joints (and wheeled legs) in the
upright posture where the arms serve the most of a table (:mod:`.torso`). They are held, not made
part of the arm chains: maps and the planner treat held joints as part of the robot.
:func:`render` writes the YAML with comments; the result loads with :func:`~placement.robots.load_robot`
unedited (:func:`propose` checks it).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from placement.errors import PlacementError, RobotError
from placement.robots.chain import extract_chain
from placement.robots.model_cache import frame_id
from placement.robots.onboarding.base import Base, find_base, load_collision, screen_collisions
from placement.robots.onboarding.rank import pose_rank, rank_warning
from placement.robots.onboarding.selfpairs import ArtefactPair, artefact_pairs
from placement.robots.onboarding.tcp import TCP, deepen, hand_reach, infer_tcp
from placement.robots.onboarding.torso import Family, limits, set_joint, tune, wheeled_legs
from placement.robots.onboarding.tree import REACH_SAMPLES, analyse, arm_names, subtree
from placement.robots.onboarding.urdf import load_description
from placement.robots.preset import Robot, matrix_to_pose
from placement.robots.spec import MIN_ARM_JOINTS, PresetSpec, parse_preset, share_dir
from placement.validation import one_line, parse_yaml

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

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "urdf": self.urdf,
            "base_frame": self.base.frame,
            "base_frame_parent": self.base.parent,
            "base_frame_xyz": None if self.base.xyz is None else list(self.base.xyz),
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
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    tcps = [infer_tcp(model, data, c, tree.hand[c[-1]]) for c in tree.arms]
    mesh_notes: list[str] = []
    geom, _ = load_collision(model, d.xml, d.path, mesh_notes)
    if geom is not None:  # fingers reaching far beyond a palm-centred grasp frame: a deeper TCP
        for k, c in enumerate(tree.arms):
            tip = data.oMf[frame_id(model, tcps[k].tip_frame)].homogeneous
            reach, link = hand_reach(model, q, geom, set(subtree(model, c[-1])), tip @ tcps[k].offset)
            tcps[k] = deepen(tcps[k], reach, link)
    names, side_notes = arm_names(model, tree.arms, [float(data.oMi[c[-1]].translation[1]) for c in tree.arms])
    families = [Family([tree.torso], "torso")] if tree.torso else []
    actuated = {j for j in range(1, model.njoints) if model.joints[j].nv == 1 and model.names[j] not in d.mimic}
    legs = wheeled_legs(model, actuated, moved | set(tree.torso))
    if legs:
        families.append(Family(legs, "legs"))
    fixed, q_held, torso_notes = tune(model, q, families, tree.arms, tcps, geom, moved) if families else ({}, q, [])
    base = find_base(model, d.xml, d.path, q_held, moved)
    root = next(i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY)
    reach_notes, rank_warnings = [], []
    for name, chain, tcp in zip(names, tree.arms, tcps):
        high, far = tree.reach[chain[-1]]
        reach_notes.append(
            f"{name} arm: its end reaches {high:.2f} m above the robot's lowest point and {far:.2f} m from the "
            f"root's vertical axis over {REACH_SAMPLES} sampled configurations"
        )
        qc = q_held.copy()
        for j in chain:
            set_joint(model, qc, j, 0.0)
        ch = extract_chain(model, qc, root, chain, frame_id(model, tcp.tip_frame), tcp.offset, ("init", name), data)
        bounds = np.array([limits(model, j)[:2] for j in chain])
        w = rank_warning(name, pose_rank(ch, bounds[:, 0], bounds[:, 1]))
        if w:
            rank_warnings.append(w)
    arms = []
    for name, chain, tcp in zip(names, tree.arms, tcps):
        lim = [limits(model, j) for j in chain]
        home = [0.0 if c else round((lo + hi) / 2, 4) for lo, hi, c in lim]
        arms.append(ArmProposal(name, [model.names[j] for j in chain], tcp, home, [c for _, _, c in lim]))
    warnings = d.notes + mesh_notes + list(base.warnings) + rank_warnings
    warnings += [f"arm '{a.name}': {a.tcp.how}" for a in arms if a.tcp.guessed]
    others = [n for names_, why in tree.rejected for n in names_ if n not in fixed]
    notes = base.notes + side_notes + reach_notes + torso_notes
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
