"""Transfers: a pick and its place are one motion of one arm holding the object by one grasp.

The object is set down as it was held. A place location says where the *object* goes; the hand's
pose there follows from the grasp:

* the object's allowed orientations at the place are its orientation when picked turned about the
  vertical: by each of the planner's ``grasp_yaws`` (relative to the picked yaw), or by the turns
  the location lists in ``orientations`` (object orientations in the world frame, each within
  :data:`UPRIGHT_TOLERANCE` of the picked orientation turned about z, snapped onto it);
* the object stands centred on the location's (x, y), its lowest point on the support surface:
  the highest top face of an obstacle (box or cylinder) under (x, y) whose top lies between
  ``z - SUPPORT_SEARCH`` and ``z`` (so a version 1 file's TCP target 0.1 m above a table finds the
  table), else ``z`` itself;
* the place trajectory is the grasp trajectory carried along: ``T_place_obj @ inv(T_pick_obj) @
  grasp_pose`` for every pose of the grasp (pre-pose first), so the pre-place pose is the grasp's
  pre-grasp retreat along its approach, relative to the object.

Place candidates are named ``GRASP@yawDEG`` (the turn about z relative to the picked yaw, degrees)
or ``GRASP@orientationK`` and remember the grasp (:attr:`Candidate.grasp`), the object's pose at
the place and its support.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from placement.collision.held import Held
from placement.planning.arrays import FloatArray
from placement.planning.problems.grasps import Candidate
from placement.scene import Box, PlaceLocation, Polygon, Scene, SceneObject
from placement.scene.places import UPRIGHT_TOLERANCE_DEG
from placement.scene.poses import quaternion_matrix, yaw_quaternion

#: [m] how far below a place location's z a support surface is looked for.
SUPPORT_SEARCH = 0.25
#: [rad] how far an object may tilt between its pick and its place.
UPRIGHT_TOLERANCE = math.radians(UPRIGHT_TOLERANCE_DEG)


def rot_z(a: float) -> FloatArray:
    """(3, 3) rotation by ``a`` [rad] about z."""
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def tilt_between(Ra: FloatArray, Rb: FloatArray) -> float:
    """Angle [rad] between the world z axis and its image under ``Ra Rb^T``: 0 when the two
    orientations (3, 3) differ by a turn about the vertical only."""
    return math.acos(float(np.clip((Ra @ Rb.T)[2, 2], -1.0, 1.0)))


def turn_about_z(Ra: FloatArray, Rb: FloatArray) -> float:
    """The yaw [rad] of the turn about z closest to ``Ra Rb^T`` (3, 3)."""
    D = Ra @ Rb.T
    return math.atan2(D[1, 0] - D[0, 1], D[0, 0] + D[1, 1])


def obj_rotation(obj: SceneObject) -> FloatArray:
    """(3, 3) the orientation of ``obj`` (set from its yaw when the scene gives none)."""
    q = obj.orientation
    return quaternion_matrix(q if q is not None else yaw_quaternion(obj.yaw))


def half_height(R: FloatArray, size: npt.ArrayLike) -> float:
    """Half the vertical extent [m] of a box of edge lengths ``size`` (3,) with axes ``R`` (3, 3)."""
    return float(np.abs(R[2]) @ (np.asarray(size, dtype=float) / 2))


def support_surface(scene: Scene, x: float, y: float, z: float) -> tuple[float, str | None]:
    """(height [m], obstacle name) of the surface an object set down at (x, y) near height ``z``
    rests on (see the module docstring); (z, None) when no obstacle top is there."""
    best: tuple[float, str | None] = (-math.inf, None)
    for ob in scene.obstacles:
        sh = ob.shape
        if isinstance(sh, Polygon):
            continue  # a polygon prism has no top
        top = float(sh.center[2] + (sh.size[2] if isinstance(sh, Box) else sh.height) / 2)
        if not z - SUPPORT_SEARCH <= top <= z + 1e-9 or top <= best[0]:
            continue
        dx, dy = x - float(sh.center[0]), y - float(sh.center[1])
        if isinstance(sh, Box):
            c, s = math.cos(sh.yaw), math.sin(sh.yaw)
            inside = abs(c * dx + s * dy) <= sh.size[0] / 2 and abs(-s * dx + c * dy) <= sh.size[1] / 2
        else:
            inside = math.hypot(dx, dy) <= sh.radius
        if inside:
            best = (top, ob.name)
    return (z, None) if best[1] is None else best


def place_orientations(
    obj: SceneObject, loc: PlaceLocation, grasp_yaws: int | Sequence[float]
) -> list[tuple[str, FloatArray]]:
    """(label, (3, 3) world orientation) of every allowed orientation of ``obj`` at ``loc``: its
    picked orientation turned about z by the listed orientations' turns, else by ``grasp_yaws`` (a
    count evenly over a turn, or a list of turns [rad])."""
    R0 = obj_rotation(obj)
    if loc.orientations is not None:
        return [
            (f"orientation{k}", rot_z(turn_about_z(quaternion_matrix(q), R0)) @ R0)
            for k, q in enumerate(loc.orientations)
        ]
    if isinstance(grasp_yaws, (int, np.integer)):
        turns = [2 * math.pi * k / int(grasp_yaws) for k in range(int(grasp_yaws))]
    else:
        turns = [float(a) for a in grasp_yaws]
    return [(f"yaw{round(math.degrees(a))}", rot_z(a) @ R0) for a in turns]


def placed_pose(scene: Scene, obj: SceneObject, loc: PlaceLocation, R: FloatArray) -> tuple[FloatArray, str | None]:
    """((4, 4) world pose of ``obj`` set down at ``loc`` with orientation ``R`` (3, 3), support name)."""
    x, y, z = (float(v) for v in loc.position)
    top, support = support_surface(scene, x, y, z)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = (x, y, top + half_height(R, obj.size))
    return T, support


def transfer_places(
    scene: Scene, obj: SceneObject, loc: PlaceLocation, grasps: Sequence[Candidate], grasp_yaws: int | Sequence[float]
) -> list[Candidate]:
    """The place candidates of ``obj`` at ``loc`` for each of its ``grasps`` (world-frame pick
    trajectories): per grasp and allowed orientation, the grasp carried to the object's place pose."""
    T_pick_inv = np.linalg.inv(obj.pose)
    out = []
    for label, R in place_orientations(obj, loc, grasp_yaws):
        T_place, support = placed_pose(scene, obj, loc, R)
        carry = T_place @ T_pick_inv
        for g in grasps:
            out.append(
                Candidate(
                    f"{g.name}@{label}", settled(carry @ g.poses), grasp=g.name, object_pose=T_place, support=support
                )
            )
    return out


def settled(poses: FloatArray) -> FloatArray:
    """``poses`` (P, 4, 4) with the rounding noise of the composition removed (positions to 1 nm,
    rotations to 1e-12): turns of one place that put the TCP at the same point then share their map
    slices and IRM pass bit for bit, and equal trajectories of two grasps (``top@yaw180`` and
    ``top-flipped@yaw0``) are one IRM (the candidates of a place cost 8 passes instead of 16 or
    more)."""
    out = np.round(poses, 12)
    out[:, :3, 3] = np.round(poses[:, :3, 3], 9)
    return out


def held_object(obj: SceneObject, cand: Candidate) -> Held:
    """What the gripper holds along the place candidate ``cand``: ``obj`` at ``cand.object_pose``,
    rigidly attached to the TCP of its last pose."""
    return Held(
        obj.name, np.asarray(obj.size, dtype=float), np.linalg.inv(cand.poses[-1]) @ cand.object_pose, cand.support
    )


__all__ = [
    "Held",
    "SUPPORT_SEARCH",
    "UPRIGHT_TOLERANCE",
    "held_object",
    "place_orientations",
    "placed_pose",
    "support_surface",
    "tilt_between",
    "transfer_places",
    "turn_about_z",
]
