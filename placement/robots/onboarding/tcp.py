"""Tip frame and canonical TCP of an arm found by ``placement robots init``.

The canonical TCP has z along the approach (out of the gripper) and y across the fingers. Inference,
at the reference configuration (fingers as the URDF's neutral pose has them):

1. *finger points*: origins of the frames below the arm's last joint named like fingers (the frames of
   the hand's moving joints included); the ones named ``tip`` when there are such;
2. approach: from the wrist (the last arm joint's origin) to the finger points' centroid; with no
   finger points, from the wrist to a named tool frame, else to the link rigid with the wrist
   farthest from it when that is more than :data:`HAND_OFFSET` away (a fixed hand), else the last
   joint's axis pointing away from the joint before it. A hand with *one moving jaw* (every finger frame on one hand joint, the
   other jaw part of the last link: the SO-101) has its finger frame on the jaw's hinge, off to one
   side (50 deg off the SO-101's ``gripper_frame_link``): its approach points from the wrist to the
   named tool frame when there is one;
3. closing direction: one moving jaw's motion (across its hinge axis and the approach, or along its
   slide); else the finger points' widest spread across the approach; else (fingers that touch at the
   neutral pose, a Franka hand's) the first finger joint's motion across the approach; else the tip
   frame's axis most orthogonal to the approach;
4. tip frame: a frame rigid with the last arm joint named tcp > grasp > tool > gripper > tip that is not
   behind the fingers (more than :data:`BEHIND` [m]), a frame the URDF adds before the link's own
   body frame of the same rank (``gripper_frame_link`` before ``gripper_link``), else the last link;
   the TCP sits at the named frame's origin, else at the finger points' centroid, else at the last
   link's origin;
5. axes within :data:`SNAP` of one of the tip frame's axes are snapped to it (clean quaternions);
6. depth (:func:`deepen`): the canonical TCP is where the fingertips close, as a parallel gripper's ROS
   tool frame (the PR2's fingertips reach 0.019 m past it): generated top grasps put the TCP on the
   object's top face. A hand whose collision shapes reach more than :data:`HAND_REACH_MAX` beyond the
   TCP along the approach (a palm-centred grasp frame such as TIAGo's ``hand_grasping_frame``: 0.095 m)
   would push its fingers that far into the object and the table below; its TCP moves forward along
   the approach to :data:`GRASP_DEPTH` short of the hand's far end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from placement.robots.onboarding.tree import named_like, words

if TYPE_CHECKING:
    import coal

#: A frame named ``tip`` (a ball hand's end, ``ball1_tip``) ranks last: used when nothing else is named.
TIP_WORDS = ("tcp", "grasp", "tool", "gripper", "tip")
#: Frames rigid with the last arm joint named so are finger points (fixed fingers of a reduced model).
FINGER_WORDS = ("finger", "thumb", "phalanx", "knuckle", "claw", "jaw")
#: Finger points spread less than this across the approach [m] do not give a closing direction.
MIN_SPREAD = 0.005
#: A named frame more than this far behind the finger centroid along the approach is not the TCP [m].
BEHIND = 0.05
#: Largest angle between an inferred axis and a tip frame axis for snapping [rad].
SNAP = math.radians(20)
#: A hand reaching farther than this beyond its TCP along the approach gets a deeper TCP [m].
HAND_REACH_MAX = 0.04
#: How far the fingertips reach past a moved TCP [m] (the PR2's: 0.019 m).
GRASP_DEPTH = 0.02
#: A link rigid with the last arm joint this far from it [m] is a fixed hand the approach points to.
HAND_OFFSET = 0.05


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


def finger_frames(model: pin.Model, last: int, hand: list[int]) -> list[int]:
    """Ids of the finger frames of the hand after joint ``last`` (see the module doc)."""
    moving = set(hand)
    ids = [
        i
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY
        and (f.parentJoint in moving or (f.parentJoint == last and named_like(f.name, FINGER_WORDS)))
    ]
    tips = [i for i in ids if any(w.startswith("tip") or w.endswith("tip") for w in words(model.frames[i].name))]
    return tips or ids


def finger_points(model: pin.Model, data: pin.Data, last: int, hand: list[int]) -> np.ndarray:
    """(k, 3) origins [m] of the finger frames of the hand after joint ``last`` (see the module doc)."""
    return np.array([data.oMf[i].translation for i in finger_frames(model, last, hand)]).reshape(-1, 3)


def single_jaw(model: pin.Model, last: int, hand: list[int]) -> int | None:
    """The joint id of the one moving jaw when every finger frame rides on that one hand joint (the
    other jaw is part of the last link: an SO-101), else None."""
    joints = {model.frames[i].parentJoint for i in finger_frames(model, last, hand)}
    return joints.pop() if len(joints) == 1 and joints <= set(hand) else None


def infer_tcp(model: pin.Model, data: pin.Data, chain: list[int], hand: list[int]) -> TCP:
    """Tip frame and TCP of the arm ``chain`` (joint ids) with data from framesForwardKinematics."""
    last = chain[-1]
    wrist = data.oMi[last].translation
    P = finger_points(model, data, last, hand)
    jaw = single_jaw(model, last, hand)
    centroid = P.mean(axis=0) if len(P) else None
    rigid = [i for i, f in enumerate(model.frames) if f.parentJoint == last and f.type == pin.FrameType.BODY]
    link = rigid[0]  # the body frame of the last joint's child link comes first
    # equal names: a frame the URDF adds for the purpose (gripper_frame_link) before the link's own (gripper_link)
    ranked = [(r, i) for i in rigid if (r := _tip_rank(model.frames[i].name)) is not None]
    named = [
        (r, i)
        for r, _, i in sorted(
            (r, i == link, i) for r, i in ranked if not named_like(model.frames[i].name, FINGER_WORDS)
        )
    ]
    ahead = [(r, i) for r, i in named if np.linalg.norm(data.oMf[i].translation - wrist) > 0.01]
    guessed = False
    if jaw is not None and ahead:
        # the one jaw's frame sits on its hinge, off to one side: the fingers' centroid would tilt the approach
        named = ahead
        z = _unit(data.oMf[named[0][1]].translation - wrist)
        how = (
            f"one moving jaw ('{model.names[jaw]}', its frame on its hinge): approach from the wrist towards "
            f"the frame '{model.frames[named[0][1]].name}'"
        )
    elif centroid is not None and np.linalg.norm(centroid - wrist) > 1e-3:
        z = _unit(centroid - wrist)
        how = f"approach from the wrist towards the centroid of {len(P)} finger frames"
        reach = float(z @ (centroid - wrist))
        named = [(r, i) for r, i in named if float(z @ (data.oMf[i].translation - wrist)) >= reach - BEHIND]
    elif named and np.linalg.norm(data.oMf[named[0][1]].translation - wrist) > 0.01:
        z = _unit(data.oMf[named[0][1]].translation - wrist)
        how = f"no fingers found; approach from the wrist towards the frame '{model.frames[named[0][1]].name}'"
    elif (hand_link := _far_rigid_body(model, data, rigid, wrist)) is not None:
        z = _unit(data.oMf[hand_link].translation - wrist)
        how = (
            f"no fingers and no tool frame found; approach from the wrist towards the link "
            f"'{model.frames[hand_link].name}' rigid with it (a fixed hand? check it)"
        )
        guessed = True  # a wrist camera would look the same: said as a warning
    else:
        axis = data.oMi[last].rotation @ _joint_axis(model, last)
        before = data.oMi[model.parents[last]].translation
        z = axis if axis @ (wrist - before) >= 0 else -axis
        how = "no fingers and no tool frame found: approach along the last joint's axis (GUESSED: check it)"
        guessed = True
    tip = named[0][1] if named else link
    R_tip = data.oMf[tip].rotation
    z = _snap(z, R_tip)
    spread = P - P.mean(axis=0) if len(P) and jaw is None else np.zeros((1, 3))
    spread -= np.outer(spread @ z, z)
    _, sv, vt = np.linalg.svd(spread, full_matrices=False)
    motion = _jaw_motion(model, data, jaw, z) if jaw is not None else np.zeros(3)
    if np.linalg.norm(motion - (motion @ z) * z) > 0.5:
        y = motion
        how += "; y along the jaw's motion"
    elif sv[0] / math.sqrt(len(spread)) >= MIN_SPREAD:
        y = vt[0]
        how += "; y across the fingers' widest spread"
    elif (fingers := _fingers_motion(model, data, last, hand, z)) is not None:
        y, joint = fingers
        how += f"; y along the motion of finger joint '{joint}' (the fingers touch at the neutral pose)"
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
    offset[:3, 3] = np.round(offset[:3, 3], 4) + 0.0  # no -0.0 in the preset
    return TCP(model.frames[tip].name, offset, how, guessed, P)


def _far_rigid_body(model: pin.Model, data: pin.Data, rigid: list[int], wrist: np.ndarray) -> int | None:
    """The link (body frame) rigid with the last arm joint farthest from the wrist, when it is more
    than :data:`HAND_OFFSET` away (a fixed hand or tool mounted on the wrist: ARMAR-6's
    ``hand_fixed_r0``, 0.26 m out), else None."""
    far = max(rigid, key=lambda i: float(np.linalg.norm(data.oMf[i].translation - wrist)), default=None)
    if far is None or np.linalg.norm(data.oMf[far].translation - wrist) <= HAND_OFFSET:
        return None
    return far


def _jaw_motion(model: pin.Model, data: pin.Data, jaw: int, z: np.ndarray) -> np.ndarray:
    """Unit direction (3,) in the root frame in which the jaw ``jaw`` moves at the grasp: across its
    hinge axis and the approach ``z`` for a revolute jaw, along its slide for a prismatic one."""
    axis = data.oMi[jaw].rotation @ _joint_axis(model, jaw)
    revolute = np.linalg.norm(_joint_motion(model, jaw)[3:]) > 0.5
    return _unit(np.cross(axis, z)) if revolute else axis


def _fingers_motion(
    model: pin.Model, data: pin.Data, last: int, hand: list[int], z: np.ndarray
) -> tuple[np.ndarray, str] | None:
    """(unit direction (3,) in the root frame, joint name) of the first hand joint that carries a finger
    frame and moves it across the approach ``z`` (a slide, or a hinge's swing), or None."""
    carriers = sorted({model.frames[i].parentJoint for i in finger_frames(model, last, hand)} & set(hand))
    for j in carriers:
        motion = _jaw_motion(model, data, j, z)
        across = motion - (motion @ z) * z
        if np.linalg.norm(across) > 0.5:
            return _unit(across), str(model.names[j])
    return None


def _joint_motion(model: pin.Model, jid: int) -> np.ndarray:
    """The 1-DoF joint ``jid``'s motion (6,) in its own frame [linear, angular]."""
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    return np.asarray(pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, model.joints[jid].idx_v])


def _joint_axis(model: pin.Model, jid: int) -> np.ndarray:
    """Unit axis (3,) of the 1-DoF joint ``jid`` in its own frame (revolute: rotation, prismatic: slide)."""
    motion = _joint_motion(model, jid)
    ang, lin = motion[3:], motion[:3]
    return _unit(ang if np.linalg.norm(ang) > 0.5 else lin)


def _points(geometry: coal.CollisionGeometry) -> np.ndarray:
    """(k, 3) points [m] in the shape's frame that bound it: a mesh's vertices, else its local box's corners."""
    try:
        V = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
        if len(V):
            return V
    except Exception:  # primitives (box, cylinder, sphere) have no vertices
        pass
    geometry.computeLocalAABB()
    lo, hi = np.array(geometry.aabb_local.min_), np.array(geometry.aabb_local.max_)
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def hand_reach(
    model: pin.Model, q: np.ndarray, geom: pin.GeometryModel, joints: set[int], tcp_world: np.ndarray
) -> tuple[float, str | None]:
    """How far [m] the collision shapes on ``joints`` reach beyond the TCP ``tcp_world`` (4, 4, root
    frame at ``q``) along its z (the approach), and the link of the farthest point (-inf, None: no shape)."""
    data, gdata = model.createData(), geom.createData()
    pin.updateGeometryPlacements(model, data, geom, gdata, q)
    best, link = -math.inf, None
    z, o = tcp_world[:3, 2], tcp_world[:3, 3]
    for k, obj in enumerate(geom.geometryObjects):
        if obj.parentJoint not in joints:
            continue
        M = gdata.oMg[k]
        far = float(((_points(obj.geometry) @ M.rotation.T + M.translation - o) @ z).max())
        if far > best:
            best, link = far, model.frames[obj.parentFrame].name
    return best, link


def deepen(tcp: TCP, reach: float, link: str | None) -> TCP:
    """``tcp`` with its origin moved forward along the approach when the hand reaches more than
    :data:`HAND_REACH_MAX` [m] beyond it (``reach``, farthest on ``link``); see the module docstring."""
    if link is None or reach <= HAND_REACH_MAX:
        return tcp
    shift = round(reach - GRASP_DEPTH, 4)
    offset = tcp.offset.copy()
    offset[:3, 3] = np.round(offset[:3, 3] + shift * offset[:3, 2], 4) + 0.0  # no -0.0 in the preset
    how = (
        f"{tcp.how}; then moved {shift:g} m forward along the approach, {GRASP_DEPTH:.2f} m short of the "
        f"hand's far end ('{link}' reaches {reach:.3f} m beyond it: a grasp at an object's top face would "
        "push the fingers into the object's support)"
    )
    return TCP(tcp.tip_frame, offset, how, tcp.guessed, tcp.finger_points)
