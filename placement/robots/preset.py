"""Robot presets: a YAML file naming a URDF, its base frame, fixed joints and arms.

Units: metres and radians; ``tcp_offset`` is ``[x, y, z, qx, qy, qz, qw]`` (ROS order).
A URDF path may be absolute, relative to the preset file, or
``package://example-robot-data/...`` (resolved inside the installed
example-robot-data package).
"""

from __future__ import annotations

import difflib
import hashlib
import importlib.metadata
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml

from ..errors import ArmNotFound, FrameNotFound, JointNotFound, PresetError, RobotError
from .chain import Chain, extract_chain

PRESET_DIR = Path(__file__).parent / "presets"

_TOP_KEYS = {
    "name": str, "urdf": str, "srdf": str, "base_frame": str, "fixed_joints": dict,
    "footprint_radius": float, "v_max": float, "omega_max": float, "arms": dict,
}
_REQUIRED = ("name", "urdf", "base_frame", "arms")
_ARM_KEYS = {"joints": list, "tip_frame": str, "tcp_offset": list, "home": list}


def builtin_presets() -> list[str]:
    """Names of the presets shipped with the package."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.yaml"))


def _share_dir() -> Path:
    dist = importlib.metadata.distribution("example-robot-data")
    return Path(dist.locate_file("cmeel.prefix/share"))


def _resolve(path: str, origin: Path) -> Path:
    if path.startswith("package://"):
        return _share_dir() / path[len("package://"):]
    p = Path(path).expanduser()
    return p if p.is_absolute() else (origin / p)


def pose_to_matrix(pose) -> np.ndarray:
    """``[x, y, z, qx, qy, qz, qw]`` (metres, unit quaternion) -> (4, 4) homogeneous matrix."""
    x, y, z, qx, qy, qz, qw = (float(v) for v in pose)
    norm = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    if abs(norm - 1.0) > 1e-6:
        raise ValueError(f"quaternion [{qx}, {qy}, {qz}, {qw}] is not unit length (norm {norm:.6g})")
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(qw, qx, qy, qz).toRotationMatrix()
    T[:3, 3] = (x, y, z)
    return T


def matrix_to_pose(T: np.ndarray) -> list[float]:
    """(4, 4) homogeneous matrix -> ``[x, y, z, qx, qy, qz, qw]``."""
    q = pin.Quaternion(np.asarray(T[:3, :3], dtype=float))
    return [float(T[0, 3]), float(T[1, 3]), float(T[2, 3]), q.x, q.y, q.z, q.w]


@dataclass
class Arm:
    """One arm of a robot: its joints in order, tip frame and canonical TCP.

    Attributes:
        name: arm name in the preset ("right", "left", ...).
        joints: joint names from the base to the tip.
        tip_frame: URDF frame the TCP is attached to.
        tcp_offset: (4, 4) fixed transform tip frame -> canonical TCP frame
            (z = approach direction, y = closing direction), metres.
        home: (n,) home configuration [rad or m].
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

    @property
    def dof(self) -> int:
        return len(self.joints)


class Robot:
    """A robot preset bound to its pinocchio model. Use :func:`load_robot`."""

    def __init__(self, spec: dict, origin: Path, source: str):
        self.source = source
        self.name: str = spec["name"]
        self.urdf_path = _resolve(spec["urdf"], origin)
        self.srdf_path = _resolve(spec["srdf"], origin) if spec.get("srdf") else None
        if not self.urdf_path.is_file():
            raise RobotError(f"robot '{self.name}': URDF not found: {self.urdf_path}")
        try:
            self.model = pin.buildModelFromUrdf(str(self.urdf_path))
        except Exception as exc:  # pinocchio raises plain RuntimeError/ValueError
            msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise RobotError(f"robot '{self.name}': URDF {self.urdf_path} does not load: {msg}") from None
        self.base_frame: str = spec["base_frame"]
        self.base_frame_id = self._frame_id(self.base_frame)
        self.fixed_joints: dict[str, float] = {}
        for jname, value in (spec.get("fixed_joints") or {}).items():
            self._joint_id(jname)
            self.fixed_joints[str(jname)] = float(value)
        self.footprint_radius = float(spec.get("footprint_radius", 0.4))
        self.v_max = float(spec.get("v_max", 0.5))
        self.omega_max = float(spec.get("omega_max", 1.0))
        for key in ("footprint_radius", "v_max", "omega_max"):
            if not getattr(self, key) > 0:
                raise PresetError(f"robot '{self.name}': {key} must be > 0, got {getattr(self, key)}")
        self.urdf_sha256 = hashlib.sha256(self.urdf_path.read_bytes()).hexdigest()
        self._arms = {name: self._make_arm(name, a) for name, a in spec["arms"].items()}

    # -- model helpers -------------------------------------------------
    def _frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            names = [f.name for f in self.model.frames]
            raise FrameNotFound(name, self.name, difflib.get_close_matches(name, names, 5, 0.4))
        return self.model.getFrameId(name)

    def _joint_id(self, name: str) -> int:
        if not self.model.existJointName(name):
            names = list(self.model.names)[1:]
            raise JointNotFound(name, self.name, difflib.get_close_matches(name, names, 5, 0.4))
        return self.model.getJointId(name)

    def reference_q(self) -> np.ndarray:
        """Pinocchio configuration: neutral, with the preset's fixed joints set."""
        q = pin.neutral(self.model)
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

    def _make_arm(self, name: str, a: dict) -> Arm:
        jids = [self._joint_id(j) for j in a["joints"]]
        tip_id = self._frame_id(a["tip_frame"])
        tcp = pose_to_matrix(a.get("tcp_offset", [0, 0, 0, 0, 0, 0, 1]))
        n = len(jids)
        lower, upper, cont, vel = (np.zeros(n) for _ in range(4))
        cont = np.zeros(n, dtype=bool)
        for i, jid in enumerate(jids):
            jm = self.model.joints[jid]
            if jm.nq == 2:
                cont[i], lower[i], upper[i] = True, -math.pi, math.pi
            else:
                lower[i] = self.model.lowerPositionLimit[jm.idx_q]
                upper[i] = self.model.upperPositionLimit[jm.idx_q]
                if not (np.isfinite(lower[i]) and np.isfinite(upper[i]) and lower[i] < upper[i]):
                    raise RobotError(
                        f"arm '{name}' of robot '{self.name}': joint '{a['joints'][i]}' has no usable "
                        f"limits ({lower[i]}, {upper[i]})"
                    )
            vel[i] = self.model.velocityLimit[jm.idx_v]
        home = np.asarray(a.get("home", (lower + upper) / 2 * ~cont), dtype=float)
        if home.shape != (n,):
            raise PresetError(f"robot '{self.name}': arms.{name}.home has {home.size} values, arm has {n} joints")
        q0 = self.reference_q()
        for jid in jids:
            self._set(q0, jid, 0.0)
        chain = extract_chain(self.model, q0, self.base_frame_id, jids, tip_id, tcp, (self.name, name))
        return Arm(name, list(a["joints"]), a["tip_frame"], tcp, home, lower, upper, cont, vel, chain, jids)

    # -- public API ----------------------------------------------------
    @property
    def arms(self) -> list[str]:
        """Arm names, in preset order."""
        return list(self._arms)

    def arm(self, name: str) -> Arm:
        """The arm called ``name``; raises :class:`ArmNotFound` naming the alternatives."""
        try:
            return self._arms[name]
        except KeyError:
            raise ArmNotFound(name, self.name, self.arms) from None

    def full_q(self, arm: str, q, reference: np.ndarray | None = None) -> np.ndarray:
        """Pinocchio configuration with ``q`` (n,) [rad/m] on ``arm`` and fixed joints set.

        ``reference``: a :meth:`reference_q` computed once, for callers in a loop.
        """
        a = self.arm(arm)
        out = self.reference_q() if reference is None else reference.copy()
        for jid, v in zip(a.joint_ids, np.asarray(q, dtype=float)):
            self._set(out, jid, float(v))
        return out

    def tcp_pose(self, arm: str, q) -> np.ndarray:
        """(4, 4) TCP pose in the base frame computed by pinocchio (the reference FK)."""
        a = self.arm(arm)
        data = self.model.createData()
        pin.framesForwardKinematics(self.model, data, self.full_q(arm, q))
        base = data.oMf[self.base_frame_id]
        tip = data.oMf[self._frame_id(a.tip_frame)]
        return (base.inverse() * tip).homogeneous @ a.tcp_offset

    @cached_property
    def fingerprint(self) -> dict:
        """What a map must match to be used with this robot."""
        return {"robot": self.name, "urdf_sha256": self.urdf_sha256, "base_frame": self.base_frame,
                "fixed_joints": dict(self.fixed_joints)}


def _check_keys(d: dict, allowed: dict, path: str) -> None:
    for key, value in d.items():
        if key not in allowed:
            raise PresetError(f"unknown key '{path}{key}'; allowed: {', '.join(sorted(allowed))}")
        want = allowed[key]
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) if want is float else isinstance(value, want)
        if not ok:
            raise PresetError(f"key '{path}{key}' must be a {want.__name__}, got {type(value).__name__}")


def load_robot(preset: str | Path = "pr2") -> Robot:
    """Load a robot from a built-in preset name or the path of a preset YAML.

    Raises :class:`PresetError` for a malformed preset (naming the key path) and
    :class:`RobotError` (or a subclass) for a URDF, frame, joint or arm problem.
    """
    preset = str(preset)
    path = PRESET_DIR / f"{preset}.yaml"
    if not path.is_file():
        path = Path(preset).expanduser()
        if not path.is_file():
            raise RobotError(
                f"unknown robot '{preset}': not a built-in preset ({', '.join(builtin_presets())}) "
                "nor a preset file"
            )
    try:
        spec = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise PresetError(f"robot preset {path} is not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(spec, dict):
        raise PresetError(f"robot preset {path} must be a mapping")
    _check_keys(spec, _TOP_KEYS, "")
    for key in _REQUIRED:
        if key not in spec:
            raise PresetError(f"robot preset {path}: missing key '{key}'")
    if not spec["arms"]:
        raise PresetError(f"robot preset {path}: 'arms' is empty")
    for name, a in spec["arms"].items():
        if not isinstance(a, dict):
            raise PresetError(f"key 'arms.{name}' must be a mapping")
        _check_keys(a, _ARM_KEYS, f"arms.{name}.")
        for key in ("joints", "tip_frame"):
            if key not in a:
                raise PresetError(f"robot preset {path}: missing key 'arms.{name}.{key}'")
    return Robot(spec, path.parent, str(path))
