"""Tip frame and canonical TCP of an arm found by ``placement robots init``.

The canonical TCP has z along the approach (out of the gripper) and y across the fingers. Inference,
at the reference configuration (fingers as the URDF's neutral pose has them):

1. *finger points*: origins of the frames below the arm's last joint named like fingers (the frames of
   the hand's moving joints included); the ones named ``tip`` when there are such;
2. approach: from the wrist (the last arm joint's origin) to the finger points' centroid; with no
   finger points, from the wrist to a named tool frame, else the last joint's axis pointing away
   from the joint before it;
3. closing direction: the finger points' widest spread across the approach; else the tip frame's axis
   most orthogonal to the approach;
4. tip frame: a frame rigid with the last arm joint named tcp > grasp > tool > gripper that is not
   behind the fingers (more than :data:`BEHIND` [m]), else the last link; the TCP sits at the named
   frame's origin, else at the finger points' centroid, else at the last link's origin;
5. axes within :data:`SNAP` of one of the tip frame's axes are snapped to it (clean quaternions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from .init_tree import named_like, words

TIP_WORDS = ("tcp", "grasp", "tool", "gripper")
#: Frames rigid with the last arm joint named so are finger points (fixed fingers of a reduced model).
FINGER_WORDS = ("finger", "thumb", "phalanx", "knuckle", "claw", "jaw")
#: Finger points spread less than this across the approach [m] do not give a closing direction.
MIN_SPREAD = 0.005
#: A named frame more than this far behind the finger centroid along the approach is not the TCP [m].
BEHIND = 0.05
#: Largest angle between an inferred axis and a tip frame axis for snapping [rad].
SNAP = math.radians(20)


@dataclass
class TCP:
    """Inferred tip frame and TCP offset.

    Attributes:
        tip_frame: frame name.
        offset: (4, 4) tip frame -> canonical TCP [m].
        how: plain words on how it was inferred (for the preset's comment).
        guessed: True when no finger and no named tool frame guided it (a warning).
        finger_points: (k, 3) finger points in the root frame [m] (for tests and plots).
    """

    tip_frame: str
    offset: np.ndarray
    how: str
    guessed: bool
    finger_points: np.ndarray


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 1e-9 else v * 0.0


def _snap(v: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``v`` (root frame) replaced by the nearest signed column of ``R`` when within :data:`SNAP`."""
    dots = R.T @ v
    k = int(np.argmax(np.abs(dots)))
    return np.sign(dots[k]) * R[:, k] if abs(dots[k]) >= math.cos(SNAP) else v


def _tip_rank(name: str) -> int | None:
    w = words(name)
    for rank, key in enumerate(TIP_WORDS):
        if any(x.startswith(key) for x in w):
            return rank
    return None


def finger_points(model: pin.Model, data: pin.Data, last: int, hand: list[int]) -> np.ndarray:
    """(k, 3) origins [m] of the finger frames of the hand after joint ``last`` (see the module doc)."""
    moving = set(hand)
    ids = [i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY
           and (f.parentJoint in moving or (f.parentJoint == last and named_like(f.name, FINGER_WORDS)))]
    tips = [i for i in ids if any(w.startswith("tip") or w.endswith("tip") for w in words(model.frames[i].name))]
    chosen = tips or ids
    return np.array([data.oMf[i].translation for i in chosen]).reshape(-1, 3)


def infer_tcp(model: pin.Model, data: pin.Data, chain: list[int], hand: list[int]) -> TCP:
    """Tip frame and TCP of the arm ``chain`` (joint ids) with data from framesForwardKinematics."""
    last = chain[-1]
    wrist = data.oMi[last].translation
    P = finger_points(model, data, last, hand)
    centroid = P.mean(axis=0) if len(P) else None
    rigid = [i for i, f in enumerate(model.frames) if f.parentJoint == last and f.type == pin.FrameType.BODY]
    link = rigid[0]  # the body frame of the last joint's child link comes first
    named = sorted((r, i) for i in rigid if (r := _tip_rank(model.frames[i].name)) is not None
                   and not named_like(model.frames[i].name, FINGER_WORDS))
    guessed = False
    if centroid is not None and np.linalg.norm(centroid - wrist) > 1e-3:
        z = _unit(centroid - wrist)
        how = f"approach from the wrist towards the centroid of {len(P)} finger frames"
        reach = float(z @ (centroid - wrist))
        named = [(r, i) for r, i in named if float(z @ (data.oMf[i].translation - wrist)) >= reach - BEHIND]
    elif named and np.linalg.norm(data.oMf[named[0][1]].translation - wrist) > 0.01:
        z = _unit(data.oMf[named[0][1]].translation - wrist)
        how = f"no fingers found; approach from the wrist towards the frame '{model.frames[named[0][1]].name}'"
    else:
        axis = data.oMi[last].rotation @ _joint_axis(model, last)
        before = data.oMi[model.parents[last]].translation
        z = axis if axis @ (wrist - before) >= 0 else -axis
        how = "no fingers and no tool frame found: approach along the last joint's axis (GUESSED: check it)"
        guessed = True
    tip = named[0][1] if named else link
    R_tip = data.oMf[tip].rotation
    z = _snap(z, R_tip)
    spread = P - P.mean(axis=0) if len(P) else np.zeros((1, 3))
    spread -= np.outer(spread @ z, z)
    _, sv, vt = np.linalg.svd(spread, full_matrices=False)
    if sv[0] / math.sqrt(len(spread)) >= MIN_SPREAD:
        y = vt[0]
        how += "; y across the fingers' widest spread"
    else:
        y = R_tip[:, int(np.argmin(np.abs(R_tip.T @ z)))]
        how += f"; y along the tip frame's {'xyz'[int(np.argmin(np.abs(R_tip.T @ z)))]} axis"
    y = _unit(y - (y @ z) * z)
    y = _snap(y, R_tip)
    y = _unit(y - (y @ z) * z)
    x = np.cross(y, z)
    origin = data.oMf[tip].translation if named else (centroid if centroid is not None else wrist)
    if named:
        how += f"; TCP at the origin of '{model.frames[tip].name}'"
    elif centroid is not None:
        how += "; TCP at the finger frames' centroid"
    R = np.column_stack([x, y, z])
    world = np.eye(4)
    world[:3, :3], world[:3, 3] = R, origin
    offset = np.linalg.inv(data.oMf[tip].homogeneous) @ world
    offset[:3, 3] = np.round(offset[:3, 3], 4)
    return TCP(model.frames[tip].name, offset, how, guessed, P)


def _joint_axis(model: pin.Model, jid: int) -> np.ndarray:
    """Unit axis (3,) of the 1-DoF joint ``jid`` in its own frame (revolute: rotation, prismatic: slide)."""
    data = model.createData()
    q = pin.neutral(model)
    pin.computeJointJacobians(model, data, q)
    motion = pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, model.joints[jid].idx_v]
    ang, lin = motion[3:], motion[:3]
    return _unit(ang if np.linalg.norm(ang) > 0.5 else lin)
