"""Robot presets: a YAML file naming a URDF, its base frame, fixed joints and arms.

Units: metres and radians; ``tcp_offset`` is ``[x, y, z, qx, qy, qz, qw]`` (ROS order).
A URDF path may be absolute, relative to the preset file, or
``package://example-robot-data/...`` (resolved inside the installed
example-robot-data package).

Loading runs in two stages, and the first failure is one error line
``<preset file>: <key path>: <problem>``: :func:`placement.robots.spec.parse_preset`
checks the YAML mapping alone (types, shapes, units, files), then :class:`Robot`
checks it against the URDF model (frames, joints, the serial chain, limits).
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Any, cast

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.errors import ArmNotFound, FrameNotFound, JointNotFound, PresetError, RobotError
from placement.robots.chain import Chain, ancestors, extract_chain
from placement.robots.model_cache import MODELS_LOCK, fk_data, frame_id, urdf_model
from placement.robots.spec import MAX_PRESET_BYTES, QUATERNION_TOLERANCE, ArmSpec, GripperSpec, PresetSpec, parse_preset
from placement.validation import Checker, one_line, read_yaml

PRESET_DIR = Path(__file__).parent / "presets"


def builtin_presets() -> list[str]:
    """Names of the presets shipped with the package."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def pose_to_matrix(pose: Iterable[float]) -> np.ndarray:
    """``[x, y, z, qx, qy, qz, qw]`` (metres, unit quaternion) -> (4, 4) homogeneous matrix."""
    x, y, z, qx, qy, qz, qw = (float(v) for v in pose)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if not abs(norm - 1.0) <= QUATERNION_TOLERANCE:
        raise ValueError(f"quaternion [{qx}, {qy}, {qz}, {qw}] is not unit length (norm {norm:.6g})")
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(qw, qx, qy, qz).toRotationMatrix()
    T[:3, 3] = (x, y, z)
    return T


def matrix_to_pose(T: np.ndarray) -> list[float]:
    """(4, 4) homogeneous matrix -> ``[x, y, z, qx, qy, qz, qw]``."""
    q = pin.Quaternion(np.asarray(T[:3, :3], dtype=float))
    return [float(T[0, 3]), float(T[1, 3]), float(T[2, 3]), q.x, q.y, q.z, q.w]


def _located(exc: RobotError, where: str, key: str) -> RobotError:
    """``exc`` (keeping its class and attributes) with the preset file and key path in front."""
    exc.args = (one_line(f"{where}: {key}: {exc}"),)
    return exc


@dataclass
class Arm:
    """One arm of a robot: its joints in order, tip frame and canonical TCP.

    Attributes:
        name: arm name in the preset ("right", "left", ...).
        joints: joint names from the base to the tip.
        tip_frame: URDF frame the TCP is attached to.
        tcp_offset: (4, 4) fixed transform tip frame -> canonical TCP frame
            (z = approach direction, y = closing direction), metres.
        home: (n,) home configuration [rad or m], within the limits.
        idle: (n,) configuration [rad or m] the arm holds while another arm works (collision
            checks place the other arms there), within the limits; the preset's ``idle`` or home.
        lower, upper: (n,) joint limits [rad or m]; continuous joints get [-pi, pi].
        continuous: (n,) bool, True for joints without limits (never penalised).
        velocity: (n,) URDF velocity limits [rad/s or m/s].
        chain: kernel-ready chain from the robot's base frame to the TCP.
    """

    name: str
    joints: list[str]
    tip_frame: str
    tcp_offset: np.ndarray
    home: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    continuous: np.ndarray
    velocity: np.ndarray
    chain: Chain
    joint_ids: list[int] = field(repr=False)
    idle: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.idle is None:
            self.idle = self.home

    @property
    def dof(self) -> int:
        return len(self.joints)


class Robot:
    """A robot preset bound to its pinocchio model. Use :func:`load_robot`.

    Raises :class:`PresetError` (or :class:`JointNotFound`, :class:`FrameNotFound`)
    naming the preset file and key path when the preset does not fit the URDF.

    Base attributes: ``footprint_radius`` [m] (a round base's radius, or the circumscribed radius
    of the polygon), ``footprint`` (k, 2) [m] counter-clockwise polygon in the base frame or None
    (round base), ``v_max`` [m/s], ``omega_max`` [rad/s]. ``ignore_collisions``: frozenset of
    frozenset({link_a, link_b}) pairs of URDF links that collision checks skip. ``gripper``: the
    gripper's geometry (:class:`~placement.robots.spec.GripperSpec`, ``max_opening`` [m]).
    """

    def __init__(self, spec: PresetSpec):
        self.spec = spec
        self._variants: dict[tuple[tuple[str, float], ...], Robot] = {}
        self.source = spec.where
        self.name = spec.name
        self.urdf_path = spec.urdf
        self.srdf_path = spec.srdf
        self._check = Checker(spec.where, PresetError)
        self.model, self._mimic, self.urdf_sha256 = urdf_model(spec.urdf, spec.where)
        self.base_frame = spec.base_frame
        self.base_frame_parent, self.base_frame_xyz = spec.base_frame_parent, spec.base_frame_xyz
        if spec.base_frame_parent is not None and spec.base_frame_xyz is not None:
            self._define_base_frame(spec.base_frame, spec.base_frame_parent, spec.base_frame_xyz)
        self.base_frame_id = self._frame_id(spec.base_frame, "base_frame")
        self.fixed_joints: dict[str, float] = {}
        for jname, value in spec.fixed_joints.items():
            key = f"fixed_joints.{jname}"
            lower, upper, continuous = self._limits(self._joint_id(jname, key))
            if not continuous and not lower <= value <= upper:
                self._check.fail(key, f"{value:g} is outside the URDF limits [{lower:g}, {upper:g}] of '{jname}'")
            self.fixed_joints[jname] = value
        self.footprint_radius = spec.footprint_radius
        self.footprint = None if spec.footprint is None else np.array(spec.footprint, dtype=float)
        self.v_max = spec.v_max
        self.omega_max = spec.omega_max
        self.gripper: GripperSpec = spec.gripper
        data = self.model.createData()
        self._arms = {name: self._make_arm(a, data) for name, a in spec.arms.items()}
        self.ignore_collisions = frozenset(
            frozenset(self._link(name, f"ignore_collisions[{i}][{k}]") for k, name in enumerate(pair))
            for i, pair in enumerate(spec.ignore_collisions)
        )

    # -- model helpers -------------------------------------------------
    def _define_base_frame(self, name: str, parent: str, xyz: tuple[float, float, float]) -> None:
        """Add the preset's base frame: an operational frame ``xyz`` [m] from URDF frame ``parent``, its axes."""
        if self.model.existFrame(name):
            self._check.fail("base_frame", f"'{name}' is already a URDF frame; a defined base frame needs a new name")
        f = self.model.frames[pid := self._frame_id(parent, "base_frame_parent")]
        at = f.placement * pin.SE3(np.eye(3), np.array(xyz, dtype=float))
        self.model.addFrame(pin.Frame(name, f.parentJoint, pid, at, pin.FrameType.OP_FRAME))

    def _frame_id(self, name: str, key: str | None = None) -> int:
        if not self.model.existFrame(name):
            names = [f.name for f in self.model.frames]
            exc = FrameNotFound(name, self.name, difflib.get_close_matches(name, names, 5, 0.4))
            raise (exc if key is None else _located(exc, self._check.where, key))
        return frame_id(self.model, name)

    def _link(self, name: str, key: str) -> str:
        """``name`` if the URDF has a link of that name (a BODY frame in pinocchio)."""
        links = [f.name for f in self.model.frames if f.type == pin.FrameType.BODY]
        if name not in links:
            exc = FrameNotFound(name, self.name, difflib.get_close_matches(name, links, 5, 0.4))
            exc.args = (f"link{str(exc)[len('frame') :]}",)
            raise _located(exc, self._check.where, key)
        return name

    def _joint_id(self, name: str, key: str, arm: bool = False) -> int:
        """Id of the 1-DoF joint ``name`` (``key``: its place in the preset, for errors)."""
        m = self.model
        if not m.existJointName(name):
            if m.existFrame(name, pin.FrameType.FIXED_JOINT):
                self._check.fail(key, f"'{name}' is a fixed joint in the URDF: it cannot move")
            names = list(m.names)[1:]
            exc = JointNotFound(name, self.name, difflib.get_close_matches(name, names, 5, 0.4))
            raise _located(exc, self._check.where, key)
        if arm and name in self._mimic:
            self._check.fail(
                key, f"'{name}' is a mimic joint (it follows '{self._mimic[name]}'); arm joints must move independently"
            )
        jid: int = m.getJointId(name)
        nv = m.joints[jid].nv
        if nv != 1:
            self._check.fail(
                key,
                f"joint '{name}' has {nv} degrees of freedom; only revolute, "
                "continuous and prismatic joints can be used",
            )
        return jid

    def _limits(self, jid: int) -> tuple[float, float, bool]:
        """(lower, upper [rad or m], continuous) of a 1-DoF joint; continuous joints get [-pi, pi]."""
        jm = self.model.joints[jid]
        if jm.nq == 2:
            return -math.pi, math.pi, True
        return float(self.model.lowerPositionLimit[jm.idx_q]), float(self.model.upperPositionLimit[jm.idx_q]), False

    def _check_chain(self, a: ArmSpec, jids: list[int], tip_id: int) -> None:
        """Every arm joint lies on the serial chain base frame -> tip frame, listed base first."""
        tip_chain = ancestors(self.model, self.model.frames[tip_id].parentJoint)
        base_chain = ancestors(self.model, self.model.frames[self.base_frame_id].parentJoint)
        for i, (j, jid) in enumerate(zip(a.joints, jids)):
            key = f"arms.{a.name}.joints[{i}]"
            if jid not in tip_chain:
                self._check.fail(
                    key,
                    f"joint '{j}' is not on the chain from base frame '{self.base_frame}' "
                    f"to tip frame '{a.tip_frame}' (it does not move the tip)",
                )
            if jid in base_chain:
                self._check.fail(
                    key,
                    f"joint '{j}' moves the base frame '{self.base_frame}'; arm joints "
                    "must lie between the base frame and the tip frame",
                )
            # tip_chain is ordered tip first: a joint nearer the base has a larger index
            if i and tip_chain.index(jid) > tip_chain.index(jids[i - 1]):
                self._check.fail(
                    key,
                    f"joints must be listed from the base to the tip; '{j}' is nearer "
                    f"the base than '{a.joints[i - 1]}'",
                )

    def reference_q(self) -> np.ndarray:
        """Pinocchio configuration: neutral, with the preset's fixed joints set."""
        q: np.ndarray = pin.neutral(self.model)
        for jname, value in self.fixed_joints.items():
            self._set(q, self.model.getJointId(jname), value)
        return q

    def _set(self, q: np.ndarray, jid: int, value: float) -> None:
        jm = self.model.joints[jid]
        if jm.nq == 2:  # continuous joint: (cos, sin)
            q[jm.idx_q] = math.cos(value)
            q[jm.idx_q + 1] = math.sin(value)
        else:
            q[jm.idx_q] = value

    def _make_arm(self, a: ArmSpec, data: pin.Data) -> Arm:
        path = f"arms.{a.name}"
        jids = [self._joint_id(j, f"{path}.joints[{i}]", arm=True) for i, j in enumerate(a.joints)]
        tip_id = self._frame_id(a.tip_frame, f"{path}.tip_frame")
        self._check_chain(a, jids, tip_id)
        n = len(jids)
        lower, upper, vel = np.zeros(n), np.zeros(n), np.zeros(n)
        cont = np.zeros(n, dtype=bool)
        for i, jid in enumerate(jids):
            lower[i], upper[i], cont[i] = self._limits(jid)
            if not (np.isfinite(lower[i]) and np.isfinite(upper[i]) and lower[i] < upper[i]):
                self._check.fail(
                    f"{path}.joints[{i}]",
                    f"joint '{a.joints[i]}' has no usable limits ({lower[i]:g}, {upper[i]:g}) in the URDF",
                )
            vel[i] = self.model.velocityLimit[self.model.joints[jid].idx_v]
        home = (lower + upper) / 2 * ~cont if a.home is None else np.array(a.home, dtype=float)
        idle = home if a.idle is None else np.array(a.idle, dtype=float)
        for key, values in (("home", home), ("idle", idle)):
            for k in np.flatnonzero(~cont & ((values < lower) | (values > upper))):
                self._check.fail(
                    f"{path}.{key}[{k}]",
                    f"{values[k]:g} is outside the limits [{lower[k]:g}, {upper[k]:g}] of joint '{a.joints[k]}'",
                )
        tcp = pose_to_matrix(a.tcp_offset)
        q0 = self.reference_q()
        for jid in jids:
            self._set(q0, jid, 0.0)
        chain = extract_chain(self.model, q0, self.base_frame_id, jids, tip_id, tcp, (self.name, a.name), data)
        return Arm(a.name, list(a.joints), a.tip_frame, tcp, home, lower, upper, cont, vel, chain, jids, idle)

    # -- public API ----------------------------------------------------
    @property
    def arms(self) -> list[str]:
        """Arm names, in preset order."""
        return list(self._arms)

    @property
    def mimic_joints(self) -> frozenset[str]:
        """The URDF's mimic joints (each follows another; the model keeps no record of them), of the
        bytes the robot was built from."""
        return frozenset(self._mimic)

    def arm(self, name: str) -> Arm:
        """The arm called ``name``; raises :class:`ArmNotFound` naming the alternatives."""
        try:
            return self._arms[name]
        except KeyError:
            raise ArmNotFound(name, self.name, self.arms) from None

    def full_q(self, arm: str, q: npt.ArrayLike, reference: np.ndarray | None = None) -> np.ndarray:
        """Pinocchio configuration with ``q`` (n,) [rad/m] on ``arm`` and fixed joints set.

        ``reference``: a :meth:`reference_q` computed once, for callers in a loop.
        """
        a = self.arm(arm)
        out = self.reference_q() if reference is None else reference.copy()
        for jid, v in zip(a.joint_ids, np.asarray(q, dtype=float)):
            self._set(out, jid, float(v))
        return out

    def with_fixed(self, values: Mapping[str, float]) -> Robot:
        """This robot with some of its fixed joints held at other values ({joint: value [rad or m]}),
        e.g. a torso lift set per step; ``self`` when nothing changes.
        The URDF is parsed once (see :func:`urdf_model`), the
        variants are cached; a joint that is not fixed, or a value outside its limits, raises
        :class:`PresetError` naming it."""
        unknown = [j for j in values if j not in self.fixed_joints]
        if unknown:
            self._check.fail(
                f"fixed_joints.{unknown[0]}",
                f"'{unknown[0]}' is not a fixed joint of the preset (fixed: {', '.join(self.fixed_joints) or 'none'})",
            )
        held = dict(self.fixed_joints) | {j: float(v) for j, v in values.items()}
        if held == self.fixed_joints:
            return self
        key = tuple(sorted(held.items()))
        with MODELS_LOCK:
            found = self._variants.get(key)
        if found is None:
            found = Robot(replace(self.spec, fixed_joints=held))
            with MODELS_LOCK:
                found = self._variants.setdefault(key, found)
        return found

    def tcp_pose(self, arm: str, q: npt.ArrayLike) -> np.ndarray:
        """(4, 4) TCP pose in the base frame computed by pinocchio (the reference FK)."""
        a = self.arm(arm)
        data = fk_data(self.model)
        pin.framesForwardKinematics(self.model, data, self.full_q(arm, q))
        base = data.oMf[self.base_frame_id]
        tip = data.oMf[self._frame_id(a.tip_frame)]
        return cast(np.ndarray, (base.inverse() * tip).homogeneous @ a.tcp_offset)

    @cached_property
    def fingerprint(self) -> dict[str, Any]:
        """What a map must match to be used with this robot."""
        return {
            "robot": self.name,
            "urdf_sha256": self.urdf_sha256,
            "base_frame": self.base_frame,
            "fixed_joints": dict(self.fixed_joints),
        }


def load_robot(preset: str | Path = "pr2") -> Robot:
    """Load a robot from a built-in preset name or the path of a preset YAML.

    Raises :class:`PresetError` for a preset that is malformed or does not fit
    its URDF (naming the file and the key path) and :class:`RobotError` (or a
    subclass) for a missing preset or a URDF that does not load.
    """
    preset = str(preset)
    path = PRESET_DIR / f"{preset}.yaml"
    try:
        if not path.is_file():
            path = Path(preset).expanduser()
        found = path.is_file()
    except (OSError, ValueError, RuntimeError):  # NUL bytes, unknown ~user, name too long
        found = False
    if not found:
        raise RobotError(
            f"unknown robot {preset!r}: not a built-in preset ({', '.join(builtin_presets())}) nor a preset file"
        )
    return Robot(parse_preset(read_yaml(path, PresetError, max_bytes=MAX_PRESET_BYTES), path.parent, str(path)))
