"""The torso as a placement variable: the settings of a held joint that carries every arm.

Two kinds (``TorsoSettings.kind``). **Shifted**: one map stands for every setting of a prismatic lift.

A prismatic joint whose axis is fixed in the base frame, that does not move the base frame and that lies
between the base frame and every joint of an arm moves that arm's whole chain rigidly: with the lift at
``v`` instead of the reference ``r`` (the value the preset holds it at), every TCP pose the arm reaches is
the pose at ``r`` translated by ``(v - r) * s``, ``s`` the joint's unit axis in the base frame. The map's
measure uses the TCP-frame Jacobian, which a translation does not change, so the map at ``v`` is the map
at ``r`` with its grid origin moved by ``(v - r) * s``
(:meth:`placement.maps.rmap.ReachabilityMap.at_torso`): no extra samples, no extra build time.

The build spec's ``torso`` key (:class:`~placement.maps.buildspec.TorsoSpec`) names the joint and the
settings; :func:`torso_settings` checks them against the robot before any sampling and measures ``s``
with pinocchio (not trusting the URDF axis); the result is recorded in each arm's metadata as
``torso: {joint, values, reference, shift, velocity}`` and read back by :func:`settings_from_meta`.

**Per setting**: a revolute joint (a torso pitch such as talos_reduced's ``torso_2_joint``) turns the arm's
chain, so no one map stands for two settings: the arm is built once per setting with the robot at
``robot.with_fixed({joint: v})`` (:func:`placement.maps.torso_builds.build_torso_maps`; the build time
multiplies by the number of settings), each setting's map stored as its own array
(:func:`placement.storage.schema.setting_array`), and ``at_torso(v)`` opens that map. The record then has
``kind: per_setting``, ``unit: rad``, ``shift: null`` and ``arrays`` (the stored array of each value).
The reference setting's map is the arm's own array: a map a build without the key would have written.

**Postures** (:func:`posture_settings`): robots whose arms ride on a chain of held joints (talos's torso
yaw and pitch, a legged robot's hip and knee pitches holding the chest) cannot move one joint alone to a
useful setting: a setting is a POSTURE, a value of every one of those joints. The build spec names them ``torso: {joints: [j1, ..., jn],
postures: [[v1, ..., vn], ...]}`` [m or rad per joint]; the arm is built once per posture with the
robot at ``robot.with_fixed(posture)`` (:func:`placement.maps.torso_builds.build_torso_maps`), like one
joint's per-setting builds.

The planner carries a torso setting as one number; for postures it is the posture's index (0 .. k-1 in
the spec's order; k for the preset's own posture when it is not one of them): the record maps each index
to its joint values (:meth:`TorsoSettings.held`), the time between two postures is the slowest joint's
(:meth:`TorsoSettings.seconds`), and a planned step's ``joints`` hold every torso joint's value.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.errors import MapError, PlacementError
from placement.maps.buildspec import TorsoSpec
from placement.robots import Robot
from placement.robots.chain import ancestors
from placement.robots.model_cache import frame_id
from placement.storage.schema import posture_array, setting_array

#: the lift step [m] at which the axis is measured
PROBE_M = 0.01
#: rotations and translations of the arm's frames must follow the rigid shift to this [m, dimensionless]
RIGID_TOLERANCE = 1e-9
#: pinocchio's prismatic joint models (axis x, y, z, or any axis): a shifted map
PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
#: pinocchio's bounded revolute joint models: one build per setting
REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")


@dataclass(frozen=True)
class TorsoSettings:
    """The torso settings a map stands for, as recorded in an arm's metadata (key ``torso``).

    Attributes:
        joint: the torso joint, one of the preset's fixed joints (for postures: the first of ``joints``).
        values: (k,) settings [m for a prismatic joint, rad for a revolute one], ascending, within the
            URDF limits; for postures, the indices 0 .. k-1 of the spec's postures.
        reference: the preset's held value [m or rad] (need not be in values): the setting of the arm's
            own stored array; for postures, the index of the preset's posture (k when it is not one of
            the spec's).
        shift: (3,) for a shifted map, the TCP's translation per metre of lift, in the base frame [m/m]
            (the joint's unit axis as pinocchio moves it): the map at ``v`` is the map at ``reference``
            moved by ``(v - reference) * shift`` [m]; None for one build per setting.
        velocity: the joint's URDF velocity limit [m/s or rad/s].
        unit: the unit of the settings: "m" (prismatic), "rad" (revolute) or "index" (postures).
        arrays: (k,) for one build per setting, the stored array holding each value's map (the arm's own
            array at the reference); () for a shifted map.
        joints: (n,) for postures, every torso joint; () for one joint.
        postures: (len(allowed), n) for postures, setting i's value of every joint [m or rad per joint]
            (the reference's included); () for one joint.
        velocities: (n,) for postures, each joint's URDF velocity limit [m/s or rad/s].
        units: (n,) for postures, each joint's unit ("m" or "rad").
    """

    joint: str
    values: tuple[float, ...]
    reference: float
    shift: tuple[float, float, float] | None
    velocity: float
    unit: str = "m"
    arrays: tuple[str, ...] = ()
    joints: tuple[str, ...] = ()
    postures: tuple[tuple[float, ...], ...] = ()
    velocities: tuple[float, ...] = ()
    units: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        """ "shifted" (one map moved with a rigid prismatic lift), "per_setting" (one build per setting of
        one joint) or "posture" (one build per posture of several joints)."""
        if self.joints:
            return "posture"
        return "shifted" if self.shift is not None else "per_setting"

    @property
    def label(self) -> str:
        """The torso's name in messages and for the planner: the joint, or the joints joined by "+"."""
        return "+".join(self.joints) if self.joints else self.joint

    @property
    def allowed(self) -> tuple[float, ...]:
        """Every setting [m or rad] a map view can stand for: ``values`` and the reference, ascending."""
        return tuple(sorted({*self.values, self.reference}))

    def array(self, arm: str, value: float) -> str:
        """The stored array of ``arm``'s map at setting ``value`` (one of :attr:`allowed`)."""
        if value == self.reference or self.shift is not None:
            return arm
        return self.arrays[self.values.index(value)]

    def held(self, value: float) -> dict[str, float]:
        """{joint: value [m or rad]} the robot holds at setting ``value`` (one of :attr:`allowed`): the
        joint at ``value``, or for postures every joint at posture ``value``'s values."""
        if not self.joints:
            return {self.joint: float(value)}
        return dict(zip(self.joints, self.postures[round(value)]))

    def seconds(self, a: float, b: float) -> float:
        """Time [s] from setting ``a`` to ``b`` (of :attr:`allowed`) at the URDF velocity limits: |b - a| /
        velocity, or for postures max over the joints of |b_j - a_j| / velocity_j (they move together)."""
        if not self.joints:
            return abs(float(b) - float(a)) / self.velocity
        pa, pb = self.postures[round(a)], self.postures[round(b)]
        return max(abs(y - x) / v for x, y, v in zip(pa, pb, self.velocities))

    def describe(self, value: float) -> str:
        """Setting ``value`` in words: ``torso_2_joint=0.2 rad``, or ``posture 1 (hip=0.5 rad, knee=-0.5 rad)``."""
        if not self.joints:
            return f"{self.joint}={float(value):g} {self.unit}"
        held = ", ".join(f"{j}={x:g} {u}" for (j, x), u in zip(self.held(value).items(), self.units))
        return f"posture {round(value)} ({held})"

    def offset(self, value: float) -> npt.NDArray[np.float64]:
        """(3,) translation [m] of the arm's reach at lift ``value`` [m] against the reference (a shifted
        map; zero for one build per setting, whose maps each have their own grid)."""
        if self.shift is None:
            return np.zeros(3)
        return (float(value) - self.reference) * np.asarray(self.shift, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        """The metadata record (plain JSON types); a shifted record as before kinds existed. A posture
        record's ``joint``, ``reference`` and ``velocity`` are its first joint's (the joint the preset
        holds, at the value it holds it [m or rad], and its speed), as in every record; the posture
        index of the arm's own array is ``reference_setting``."""
        out: dict[str, Any] = {
            "joint": self.joint,
            "values": [float(v) for v in self.values],
            "reference": float(self.reference),
            "shift": None if self.shift is None else [float(v) for v in self.shift],
            "velocity": float(self.velocity),
        }
        if self.shift is None:
            out.update(kind=self.kind, unit=self.unit, arrays=list(self.arrays))
        if self.joints:
            out.update(
                reference=float(self.postures[round(self.reference)][0]),
                joints=list(self.joints),
                units=list(self.units),
                velocities=[float(v) for v in self.velocities],
                postures=[[float(x) for x in p] for p in self.postures],
                reference_setting=round(self.reference),
            )
        return out


def settings_from_meta(meta: dict[str, Any]) -> TorsoSettings | None:
    """The ``torso`` record of an arm's metadata (types checked by the storage schema), or None."""
    rec = meta.get("torso")
    if rec is None:
        return None
    shift = None
    if rec.get("shift") is not None:
        sx, sy, sz = (float(v) for v in rec["shift"])
        shift = (sx, sy, sz)
    joints = tuple(str(j) for j in rec.get("joints") or ())
    return TorsoSettings(
        str(rec["joint"]),
        tuple(float(v) for v in rec["values"]),
        float(rec["reference_setting"]) if joints else float(rec["reference"]),
        shift,
        float(rec["velocity"]),
        str(rec.get("unit", "m")),
        tuple(str(a) for a in rec.get("arrays") or ()),
        joints,
        tuple(tuple(float(x) for x in p) for p in rec.get("postures") or ()),
        tuple(float(v) for v in rec.get("velocities") or ()),
        tuple(str(u) for u in rec.get("units") or ()),
    )


def _frames(robot: Robot, arm: str, q: npt.NDArray[np.float64]) -> list[pin.SE3]:
    """The arm's first joint frame and its tip frame in the base frame at pinocchio configuration ``q``."""
    model, a = robot.model, robot.arm(arm)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    base = data.oMf[robot.base_frame_id].inverse()
    return [base * data.oMi[a.joint_ids[0]], base * data.oMf[frame_id(model, a.tip_frame)]]


def measured_shift(robot: Robot, arm: str, joint: str, values: Sequence[float], where: str = "torso") -> np.ndarray:
    """(3,) the translation per metre of ``joint`` [m/m] of ``arm``'s chain in the base frame, measured by
    pinocchio FK (arm at home) between the held value r and r + PROBE_M; PlacementError unless at every
    one of ``values`` [m] the arm's first joint frame and tip frame keep their rotation and move by
    exactly (v - r) times it (to RIGID_TOLERANCE)."""
    model, a = robot.model, robot.arm(arm)
    idx = model.joints[model.getJointId(joint)].idx_q
    ref = float(robot.fixed_joints[joint])
    q = robot.full_q(arm, a.home)
    at_ref = _frames(robot, arm, q)
    q[idx] = ref + PROBE_M
    s = (_frames(robot, arm, q)[0].translation - at_ref[0].translation) / PROBE_M
    for v in values:
        q[idx] = v
        for name, was, now in zip(("first joint", "tip"), at_ref, _frames(robot, arm, q)):
            turned = float(np.abs(now.rotation - was.rotation).max())
            moved = float(np.abs(now.translation - was.translation - (v - ref) * s).max())
            if turned > RIGID_TOLERANCE or moved > RIGID_TOLERANCE:
                raise PlacementError(
                    f"{where}.joint: '{joint}' at {v:g} m does not move arm '{arm}' rigidly along a fixed axis "
                    f"(its {name} frame turns by {turned:.3g} or is off the line by {moved:.3g} m)"
                )
    return np.asarray(s, dtype=float)


def checked_joint(robot: Robot, arm: str, j: str, where: str) -> tuple[str, float]:
    """(unit, URDF velocity limit [m/s or rad/s]) of torso joint ``j``: one of the preset's fixed joints,
    prismatic (unit "m") or bounded revolute ("rad"), not moving the base frame, between the base frame
    and every joint of ``arm``, with a usable velocity limit; PlacementError naming ``where`` otherwise."""
    model = robot.model
    fixed = robot.fixed_joints
    if j not in fixed:
        raise PlacementError(
            f"{where}: '{j}' is not a fixed joint of robot '{robot.name}' "
            f"(fixed_joints: {', '.join(fixed) or 'none'}); a torso joint must be held by the preset"
        )
    jid = model.getJointId(j)
    jm = model.joints[jid]
    kind = jm.shortname()
    if kind not in PRISMATIC + REVOLUTE:
        raise PlacementError(
            f"{where}: '{j}' is a {kind.removeprefix('JointModel')} joint; "
            "only prismatic lifts and bounded revolute joints are supported"
        )
    unit = "m" if kind in PRISMATIC else "rad"
    if jid in ancestors(model, model.frames[robot.base_frame_id].parentJoint):
        raise PlacementError(f"{where}: '{j}' moves the base frame '{robot.base_frame}'")
    a = robot.arm(arm)
    for name, aid in zip(a.joints, a.joint_ids):
        if jid not in ancestors(model, aid):
            raise PlacementError(
                f"{where}: '{j}' does not carry arm '{arm}' (joint '{name}' is not moved by it): "
                "the torso joint must lie between the base frame and every joint of the arm"
            )
    velocity = float(model.velocityLimit[jm.idx_v])
    if not (math.isfinite(velocity) and velocity > 0):
        raise PlacementError(f"{where}: '{j}' has no usable velocity limit ({velocity:g} {unit}/s) in the URDF")
    return unit, velocity


def check_limits(robot: Robot, j: str, v: float, unit: str, where: str) -> None:
    """PlacementError naming ``where`` unless ``v`` [m or rad] is within joint ``j``'s URDF limits."""
    model = robot.model
    jm = model.joints[model.getJointId(j)]
    lo, hi = float(model.lowerPositionLimit[jm.idx_q]), float(model.upperPositionLimit[jm.idx_q])
    if not lo <= v <= hi:
        raise PlacementError(f"{where}: {v:g} {unit} is outside the URDF limits [{lo:g}, {hi:g}] {unit} of '{j}'")


def torso_settings(
    robot: Robot, arm: str, spec: TorsoSpec, where: str = "torso", self_collision: bool = False
) -> TorsoSettings:
    """``spec`` checked against ``robot`` and ``arm`` (``where`` names the key in errors), with its kind.

    The joint must be one of the preset's fixed joints, prismatic or revolute (bounded), not moving the
    base frame, between the base frame and every joint of the arm, and every value within its URDF
    limits; PlacementError naming the culprit otherwise. A prismatic lift gives a shifted map (its shift
    measured by pinocchio); a map with ``self_collision`` (or the self-distance penalty) is then refused:
    the body the lift does not carry would stay put while the arm moves, so the shifted map would be
    wrong. A revolute joint gives one build per setting, each with its own self-collision check.
    """
    if spec.joints:  # several joints held at postures: one build per posture
        return posture_settings(robot, arm, spec, where)
    j = spec.joint
    unit, velocity = checked_joint(robot, arm, j, f"{where}.joint")
    if unit == "m" and self_collision:
        raise PlacementError(
            f"{where}: a map built with self_collision or self_distance holds the arm's clearance from the "
            "body at the reference lift only; build it without them, or without torso"
        )
    for i, v in enumerate(spec.values):
        check_limits(robot, j, v, unit, f"{where}.values[{i}]")
    fixed = robot.fixed_joints
    reference = float(fixed[j])
    if unit == "rad":
        arrays = tuple(arm if v == reference else setting_array(arm, j, v) for v in spec.values)
        return TorsoSettings(j, spec.values, reference, None, velocity, "rad", arrays)
    s = measured_shift(robot, arm, j, spec.values, where)
    return TorsoSettings(j, spec.values, reference, (float(s[0]), float(s[1]), float(s[2])), velocity)


def posture_settings(robot: Robot, arm: str, spec: TorsoSpec, where: str = "torso") -> TorsoSettings:
    """The posture record of ``spec`` (``spec.joints`` given) for ``arm`` of ``robot``: every joint one of
    the preset's fixed joints, prismatic or bounded revolute, not moving the base frame and carrying
    every joint of the arm (``{where}.joints[i]`` in errors), every value within its joint's URDF limits
    (``{where}.postures[i][k]``); PlacementError naming the key otherwise."""
    checked = [checked_joint(robot, arm, j, f"{where}.joints[{k}]") for k, j in enumerate(spec.joints)]
    units = tuple(u for u, _ in checked)
    for i, posture in enumerate(spec.postures):
        if len(posture) != len(spec.joints):  # the parser refuses it; a TorsoSpec made in code may not
            raise PlacementError(f"{where}.postures[{i}] has {len(posture)} values for {len(spec.joints)} joints")
        for k, (j, v) in enumerate(zip(spec.joints, posture)):
            check_limits(robot, j, v, units[k], f"{where}.postures[{i}][{k}]")
    preset = tuple(float(robot.fixed_joints[j]) for j in spec.joints)
    postures = tuple(tuple(float(v) for v in p) for p in spec.postures)
    reference = postures.index(preset) if preset in postures else len(postures)
    if reference == len(postures):
        postures += (preset,)
    values = tuple(float(i) for i in range(len(spec.postures)))
    arrays = tuple(arm if i == reference else posture_array(arm, i) for i in range(len(values)))
    velocities = tuple(v for _, v in checked)
    return TorsoSettings(
        spec.joint,
        values,
        float(reference),
        None,
        velocities[0],
        "index",
        arrays,
        spec.joints,
        postures,
        velocities,
        units,
    )


def check_torso(
    robot: Robot, arms: Sequence[str], spec: TorsoSpec, where: str = "torso", self_collision: bool = False
) -> dict[str, TorsoSettings]:
    """{arm: :func:`torso_settings`} for every arm to build (before any sampling)."""
    return {arm: torso_settings(robot, arm, spec, where, self_collision) for arm in arms}


#: a requested setting matches an allowed one this closely [m or rad] (and is replaced by it)
VALUE_TOLERANCE = 1e-9


def allowed_value(settings: TorsoSettings, value: float, where: str) -> float:
    """The allowed setting [m or rad] equal to ``value`` (to VALUE_TOLERANCE), else MapError naming the allowed
    ones."""
    v = float(value)
    for x in settings.allowed:
        if abs(x - v) <= VALUE_TOLERANCE:
            return x
    shown = ", ".join(f"{x:g}" for x in settings.allowed)
    u = settings.unit
    if settings.joints:
        raise MapError(f"{where}: no map for posture {v:g} of {settings.label}; the map stands for postures {shown}")
    raise MapError(f"{where}: no map for {settings.joint} at {v:g} {u}; the map stands for {shown} {u}")
