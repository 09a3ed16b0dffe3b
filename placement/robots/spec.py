"""First stage of loading a preset: the parsed YAML mapping checked on its own, without the URDF.

:func:`parse_preset` checks types, shapes, finiteness, signs and units, the
quaternion of every ``tcp_offset``, duplicate and conflicting joint names and
that the URDF/SRDF files exist, and returns a frozen :class:`PresetSpec`.
Everything that needs the robot model (frames, joints, limits, the chain) is
checked afterwards by :class:`placement.robots.preset.Robot`. Every failure is
one :class:`PresetError` line ``<preset file>: <key path>: <problem>``.
"""

from __future__ import annotations

import importlib.metadata
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from placement.errors import PresetError
from placement.robots.footprint import MAX_BASE_RADIUS, circumradius, parse_footprint
from placement.validation import Checker

#: Top-level keys of a preset and what they hold (repeated when a required one is missing).
TOP_KEYS = {
    "name": "robot name",
    "urdf": "URDF path: absolute, relative to the preset, or package://example-robot-data/...",
    "srdf": "SRDF path, optional",
    "base_frame": "frame on the floor under the robot: a URDF frame, or one defined by base_frame_parent",
    "base_frame_parent": "URDF frame a new base_frame is fixed to (with base_frame_xyz), optional",
    "base_frame_xyz": "[x, y, z] [m] origin of a new base_frame in base_frame_parent (same axes), optional",
    "fixed_joints": "{joint: value [rad or m]} held while mapping and planning",
    "footprint_radius": "[m] radius of a round base plus margin (or give footprint)",
    "footprint": "[[x, y], ...] [m] base outline polygon in the base frame, Nav2 convention (or footprint_radius)",
    "v_max": "[m/s] base translation speed",
    "omega_max": "[rad/s] base rotation speed",
    "arms": "{arm name: {joints, tip_frame, tcp_offset, home}}",
    "ignore_collisions": "[[link, link], ...] link pairs never checked against each other, optional",
    "gripper": "{max_opening: [m]} the gripper's geometry, optional (default the PR2's)",
}
REQUIRED = ("name", "urdf", "base_frame", "v_max", "omega_max", "arms")
ARM_KEYS = {
    "joints": "joint names from the base to the tip",
    "tip_frame": "URDF frame the TCP is attached to",
    "tcp_offset": "[x y z qx qy qz qw] tip frame -> canonical TCP [m]",
    "home": "[rad or m] one value per joint",
    "idle": "[rad or m] one value per joint: where the arm waits while another arm works (default home)",
}
ARM_REQUIRED = ("joints", "tip_frame")
GRIPPER_KEYS = {"max_opening": "[m] widest chord the gripper closes across (default 0.09, the PR2's)"}
#: Largest ``gripper.max_opening`` accepted [m]: a wider one is a units mistake.
MAX_GRIPPER_OPENING = 2.0
#: Fewest joints of an arm: with 5, the base's planar motion supplies the missing degree of freedom
#: (the maps hold the measure on the subspace the arm spans, see :mod:`placement.kernels.manipulability`).
MIN_ARM_JOINTS = 5
#: A ``tcp_offset`` quaternion whose norm is within this of 1 is accepted and normalised;
#: any other is an error (it would scale or shear the TCP frame).
QUATERNION_TOLERANCE = 1e-6
IDENTITY_POSE = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
#: Largest |x|, |y|, |z| of a ``tcp_offset`` [m]: a tool longer than this is a units mistake.
MAX_TCP_OFFSET = 10.0
#: Largest base speeds accepted [m/s], [rad/s]: beyond them the travel times lose meaning.
MAX_V, MAX_OMEGA = 100.0, 100.0
#: Largest |value| of a joint value (fixed, home, idle) [rad or m] before the URDF limits are known.
MAX_JOINT_VALUE = 1e4
#: Largest |x|, |y|, |z| of ``base_frame_xyz`` [m]: a base frame farther from its parent is a units mistake.
MAX_BASE_OFFSET = 10.0
#: Largest preset file read [bytes].
MAX_PRESET_BYTES = 4 * 2**20


@dataclass(frozen=True)
class ArmSpec:
    """One arm as written in the preset (checked, not yet bound to the model).

    Attributes:
        name: arm name.
        joints: joint names, base to tip (distinct, >= :data:`MIN_ARM_JOINTS`).
        tip_frame: URDF frame name.
        tcp_offset: (7,) ``[x, y, z, qx, qy, qz, qw]`` [m], unit quaternion.
        home: (n,) home configuration [rad or m], or None for the mid-range default.
        idle: (n,) configuration [rad or m] the arm holds while another arm works, or None (home).
    """

    name: str
    joints: tuple[str, ...]
    tip_frame: str
    tcp_offset: tuple[float, ...]
    home: tuple[float, ...] | None
    idle: tuple[float, ...] | None = None


@dataclass(frozen=True)
class GripperSpec:
    """The gripper's geometry as the planner uses it (the same for every arm).

    Attributes:
        max_opening: widest chord [m] across an object the gripper closes on (generated grasps
            close across chords up to it); default the PR2's, about 0.09 m.
    """

    max_opening: float = 0.09


@dataclass(frozen=True)
class PresetSpec:
    """A preset whose mapping is valid; ``where`` names its file in every later error.

    Attributes:
        where: the preset file as the user gave it (first word of error messages).
        name: robot name.
        urdf: resolved URDF path (an existing file).
        srdf: resolved SRDF path (an existing file) or None.
        base_frame: base frame name.
        fixed_joints: {joint: value [rad or m]}, in file order.
        footprint_radius: [m], > 0: the circle's radius, or the polygon's circumscribed radius.
        footprint: ((x, y), ...) [m] polygon in the base frame, counter-clockwise, or None for a circle.
        v_max: [m/s], > 0.
        omega_max: [rad/s], > 0.
        arms: {arm name: ArmSpec}, in file order, at least one.
        ignore_collisions: ((link, link), ...) pairs of two different link names (not yet checked
            against the URDF) that collision checks skip, like an SRDF's disabled pairs.
        gripper: the gripper's geometry (:class:`GripperSpec`; its defaults when the preset has none).
        base_frame_parent: URDF frame the base frame is fixed to when the preset defines the base frame
            (a frame no URDF has, e.g. the root link projected to the floor), else None.
        base_frame_xyz: (3,) [m] the defined base frame's origin in ``base_frame_parent`` (axes parallel
            to the parent's), or None.
    """

    where: str
    name: str
    urdf: Path
    srdf: Path | None
    base_frame: str
    fixed_joints: dict[str, float]
    footprint_radius: float
    footprint: tuple[tuple[float, float], ...] | None
    v_max: float
    omega_max: float
    arms: dict[str, ArmSpec]
    ignore_collisions: tuple[tuple[str, str], ...] = ()
    gripper: GripperSpec = GripperSpec()
    base_frame_parent: str | None = None
    base_frame_xyz: tuple[float, float, float] | None = None


def share_dir() -> Path:
    """The ``share`` folder of the installed example-robot-data package (for ``package://`` paths)."""
    dist = importlib.metadata.distribution("example-robot-data")
    return Path(str(dist.locate_file("cmeel.prefix/share")))


def resolve_path(path: str, origin: Path) -> Path:
    """``path`` as written in a preset in folder ``origin``: ``package://``, ``~``, relative or absolute."""
    if path.startswith("package://"):
        return share_dir() / path[len("package://") :]
    p = Path(path).expanduser()
    return p if p.is_absolute() else (origin / p)


def _existing_file(c: Checker, value: Any, key: str, origin: Path) -> Path:
    text = c.string(value, key)
    try:
        path = resolve_path(text, origin)
        found = path.is_file()
    except importlib.metadata.PackageNotFoundError:
        c.fail(key, f"{text} needs the example-robot-data package, which is not installed")
    except (OSError, ValueError, RuntimeError) as exc:  # NUL bytes, unknown ~user, too long
        c.fail(key, f"not a usable path: {' '.join(str(exc).split())}")
    if not found:
        c.fail(key, f"{key.upper()} file not found: {path}")
    return path


def _tcp_offset(c: Checker, value: Any, key: str) -> tuple[float, ...]:
    x, y, z, *quat = c.vector(value, key, 7, "numbers [x y z qx qy qz qw]")
    for i, v in enumerate((x, y, z)):
        if abs(v) > MAX_TCP_OFFSET:
            c.fail(f"{key}[{i}]", f"must be within +-{MAX_TCP_OFFSET:g} m, got {v:g}")
    norm = math.sqrt(sum(v * v for v in quat))
    if not abs(norm - 1.0) <= QUATERNION_TOLERANCE:
        c.fail(
            key, f"the quaternion [qx qy qz qw] must have norm 1 (within {QUATERNION_TOLERANCE:g}), got norm {norm:.9g}"
        )
    return (x, y, z, *(v / norm for v in quat))


def _joint_values(c: Checker, value: Any, key: str, n: int, joints: str) -> tuple[float, ...]:
    out = c.vector(value, key, n, f"values [rad or m], one per joint of {joints}")
    for i, v in enumerate(out):
        if abs(v) > MAX_JOINT_VALUE:
            c.fail(f"{key}[{i}]", f"must be within +-{MAX_JOINT_VALUE:g} [rad or m], got {v:g}")
    return out


def _arm(c: Checker, name: str, value: Any, fixed: dict[str, float]) -> ArmSpec:
    path = f"arms.{name}"
    a = c.mapping(value, path, ARM_KEYS, ARM_REQUIRED)
    joints = c.names(a["joints"], f"{path}.joints", MIN_ARM_JOINTS, "joint names")
    for i, j in enumerate(joints):
        if j in fixed:
            c.fail(f"{path}.joints[{i}]", f"joint '{j}' is also held in fixed_joints; list it in one of the two")
    tip = c.string(a["tip_frame"], f"{path}.tip_frame")
    tcp = _tcp_offset(c, a["tcp_offset"], f"{path}.tcp_offset") if "tcp_offset" in a else IDENTITY_POSE
    home = None
    if "home" in a:
        home = _joint_values(c, a["home"], f"{path}.home", len(joints), f"{path}.joints")
    idle = None
    if "idle" in a:
        idle = _joint_values(c, a["idle"], f"{path}.idle", len(joints), f"{path}.joints")
    return ArmSpec(name, tuple(joints), tip, tcp, home, idle)


def _link_pairs(c: Checker, value: Any, key: str) -> tuple[tuple[str, str], ...]:
    """``[[link_a, link_b], ...]``: pairs of two different link names (null: none)."""
    if value is None:
        return ()
    pairs = []
    for i, item in enumerate(c.sequence(value, key, what="link pairs [[link_a, link_b], ...]")):
        a, b = c.sequence(item, f"{key}[{i}]", 2, what="link names [link_a, link_b]")
        a, b = c.string(a, f"{key}[{i}][0]"), c.string(b, f"{key}[{i}][1]")
        if a == b:
            c.fail(f"{key}[{i}]", f"a pair of the same link '{a}'; name two different links")
        pairs.append((a, b))
    return tuple(pairs)


def _gripper(c: Checker, value: Any) -> GripperSpec:
    """``gripper: {max_opening: [m]}`` (null or absent: the defaults)."""
    if value is None:
        return GripperSpec()
    g = c.mapping(value, "gripper", GRIPPER_KEYS)
    if "max_opening" not in g:
        return GripperSpec()
    opening = c.positive(g["max_opening"], "gripper.max_opening")
    if opening > MAX_GRIPPER_OPENING:
        c.fail("gripper.max_opening", f"must be <= {MAX_GRIPPER_OPENING:g} m, got {opening:g}; it is in metres")
    return GripperSpec(opening)


def _base_shape(c: Checker, d: dict[str, Any]) -> tuple[float, tuple[tuple[float, float], ...] | None]:
    """(radius [m], polygon or None) from exactly one of ``footprint_radius`` and ``footprint``."""
    if ("footprint" in d) == ("footprint_radius" in d):
        c.fail(
            "footprint" if "footprint" in d else "footprint_radius",
            "give exactly one of footprint_radius ([m] round base) and footprint ([[x, y], ...] [m] polygon)"
            if "footprint" in d
            else f"missing required key ({TOP_KEYS['footprint_radius']})",
        )
    if "footprint_radius" in d:
        radius = c.positive(d["footprint_radius"], "footprint_radius")
        if radius > MAX_BASE_RADIUS:
            c.fail("footprint_radius", f"must be <= {MAX_BASE_RADIUS:g} m, got {radius:g}; the radius is in metres")
        return radius, None
    polygon = parse_footprint(c, d["footprint"], "footprint")
    return circumradius(polygon), polygon


def _base_definition(c: Checker, d: dict[str, Any]) -> tuple[str | None, tuple[float, float, float] | None]:
    """(base_frame_parent, base_frame_xyz [m]): both or neither."""
    if ("base_frame_parent" in d) != ("base_frame_xyz" in d):
        missing = "base_frame_xyz" if "base_frame_parent" in d else "base_frame_parent"
        c.fail(
            missing,
            f"missing: a defined base frame needs both base_frame_parent and base_frame_xyz ({TOP_KEYS[missing]})",
        )
    if "base_frame_parent" not in d:
        return None, None
    parent = c.string(d["base_frame_parent"], "base_frame_parent")
    x, y, z = c.vector(d["base_frame_xyz"], "base_frame_xyz", 3, "numbers [x y z] [m]")
    for i, v in enumerate((x, y, z)):
        if abs(v) > MAX_BASE_OFFSET:
            c.fail(f"base_frame_xyz[{i}]", f"must be within +-{MAX_BASE_OFFSET:g} m, got {v:g}")
    return parent, (x, y, z)


def parse_preset(data: Any, origin: Path, where: str) -> PresetSpec:
    """Check a parsed preset mapping (no URDF is loaded); raises :class:`PresetError`.

    Args:
        data: the parsed YAML document.
        origin: folder of the preset file (relative URDF/SRDF paths start there).
        where: the preset file as the user named it (for messages).
    """
    c = Checker(where, PresetError)
    d = c.mapping(data, "", TOP_KEYS, REQUIRED)
    name = c.string(d["name"], "name")
    base_frame = c.string(d["base_frame"], "base_frame")
    base_parent, base_xyz = _base_definition(c, d)
    held = d.get("fixed_joints")
    held = {} if held is None else c.keyed(held, "fixed_joints")
    fixed = {j: c.number(v, f"fixed_joints.{j}") for j, v in held.items()}
    for j, v in fixed.items():
        if abs(v) > MAX_JOINT_VALUE:
            c.fail(f"fixed_joints.{j}", f"must be within +-{MAX_JOINT_VALUE:g} [rad or m], got {v:g}")
    footprint_radius, footprint = _base_shape(c, d)
    v_max = c.positive(d["v_max"], "v_max")
    omega_max = c.positive(d["omega_max"], "omega_max")
    for key, v, top, unit in (("v_max", v_max, MAX_V, "m/s"), ("omega_max", omega_max, MAX_OMEGA, "rad/s")):
        if v > top:
            c.fail(key, f"must be <= {top:g} {unit}, got {v:g}")
    arms = {n: _arm(c, n, a, fixed) for n, a in c.keyed(d["arms"], "arms", minimum=1).items()}
    ignore = _link_pairs(c, d.get("ignore_collisions"), "ignore_collisions")
    gripper = _gripper(c, d.get("gripper"))
    # the files last: a typo in the mapping is reported without touching the file system
    urdf = _existing_file(c, d["urdf"], "urdf", origin)
    srdf = _existing_file(c, d["srdf"], "srdf", origin) if d.get("srdf") is not None else None
    return PresetSpec(
        where,
        name,
        urdf,
        srdf,
        base_frame,
        fixed,
        footprint_radius,
        footprint,
        v_max,
        omega_max,
        arms,
        ignore,
        gripper,
        base_parent,
        base_xyz,
    )
