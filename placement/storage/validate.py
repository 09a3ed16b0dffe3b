"""Checks of a stored map against this software and a robot: version, completeness, robot and arm identity."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

from placement.errors import MapError
from placement.storage.format import FORMAT_VERSION, READABLE_VERSIONS, ROOT_KEY

if TYPE_CHECKING:
    from placement.robots.preset import Robot

# stored and preset TCP offsets (4, 4) [m, dimensionless rotation] agree to this
TCP_TOLERANCE = 1e-9


def check_root(path: Path, root: dict[str, Any]) -> None:
    """MapError unless ``root`` is the metadata of a complete map of this format version."""
    if not root:
        raise MapError(f"{path}: not a reachability map (no '{ROOT_KEY}' metadata)")
    if root.get("complete") is not True:
        raise MapError(f"{path}: map is half-written (an interrupted build); rebuild it")
    if root.get("format_version") not in READABLE_VERSIONS:
        raise MapError(
            f"{path}: map format version {root.get('format_version')!r} is not supported "
            f"(this software reads versions {' and '.join(map(str, READABLE_VERSIONS))}, writes "
            f"{FORMAT_VERSION}); rebuild it"
        )


def base_frame_definition(robot: Robot) -> dict[str, Any] | None:
    """How the preset defines its base frame, as a map records it: None for a frame of the URDF, else
    ``{"parent": URDF frame, "xyz": [x, y, z] [m]}`` (the preset's ``base_frame_parent`` and
    ``base_frame_xyz``: a frame added at load, which the URDF hash does not cover)."""
    parent, xyz = robot.base_frame_parent, robot.base_frame_xyz
    if parent is None or xyz is None:
        return None
    return {"parent": str(parent), "xyz": [float(v) for v in xyz]}


def validate_robot(path: Path, root: dict[str, Any], robot: Robot) -> None:
    """MapError if the map at ``path`` was not built for ``robot`` as it is now."""
    if root.get("robot") != robot.name:
        raise MapError(f"{path}: map was built for robot '{root.get('robot')}', not '{robot.name}'")
    if root.get("urdf_sha256") != robot.urdf_sha256:
        raise MapError(f"{path}: map was built from another URDF of '{robot.name}' (hash differs); rebuild it")
    if root.get("base_frame") != robot.base_frame:
        raise MapError(
            f"{path}: map base frame '{root.get('base_frame')}' differs from the robot's '{robot.base_frame}'"
        )
    if "base_frame_definition" in root:  # maps built before it was recorded are accepted
        _same_base_frame(path, root["base_frame_definition"], base_frame_definition(robot), robot.base_frame)
    try:
        fixed = {k: float(v) for k, v in (root.get("fixed_joints") or {}).items()}
    except (AttributeError, TypeError, ValueError):
        fixed = None
    if fixed != robot.fixed_joints:
        raise MapError(
            f"{path}: map was built with fixed joints {root.get('fixed_joints')}, the robot holds {robot.fixed_joints}"
        )


def _same_base_frame(path: Path, stored: Any, preset: dict[str, Any] | None, name: str) -> None:
    """MapError unless the map's base frame definition is the preset's (xyz to TCP_TOLERANCE [m])."""

    def words(d: Any) -> str:
        if not isinstance(d, dict):
            return "the URDF's own frame"
        xyz = ", ".join(f"{float(v):g}" for v in d.get("xyz") or [])
        return f"a frame at [{xyz}] m in '{d.get('parent')}'"

    same = stored is None and preset is None
    if isinstance(stored, dict) and preset is not None and stored.get("parent") == preset["parent"]:
        same = bool(np.all(np.abs(np.asarray(stored.get("xyz"), dtype=float) - preset["xyz"]) <= TCP_TOLERANCE))
    if not same:
        raise MapError(
            f"{path}: map base frame '{name}' was built as {words(stored)}, the preset defines it as "
            f"{words(preset)} (base_frame_parent, base_frame_xyz); rebuild the map"
        )


def validate_arm(path: Path, meta: dict[str, Any], robot: Robot, arm: str) -> None:
    """MapError if the map of ``arm`` was built for other arm joints, tip frame or TCP offset than ``robot``'s."""
    a = robot.arm(arm)
    if meta.get("joints") != list(a.joints):
        _differs(path, arm, "joints", meta.get("joints"), list(a.joints))
    if meta.get("tip_frame") != a.tip_frame:
        _differs(path, arm, "tip frame", meta.get("tip_frame"), a.tip_frame)
    try:
        tcp = np.asarray(meta.get("tcp_offset"), dtype=float)
        same = tcp.shape == (4, 4) and bool(np.all(np.abs(tcp - a.tcp_offset) <= TCP_TOLERANCE))
    except (TypeError, ValueError):
        same = False
    if not same:
        _differs(path, arm, "TCP offset (4x4)", meta.get("tcp_offset"), a.tcp_offset)
    torso = meta.get("torso")
    if isinstance(torso, dict):  # types checked with the metadata (schema.py)
        _same_lift(path, arm, torso, robot)


def _same_lift(path: Path, arm: str, torso: dict[str, Any], robot: Robot) -> None:
    """MapError unless the torso joint the map's record names is a fixed joint the preset holds at the
    record's reference value [m or rad, the record's ``unit``] (to TCP_TOLERANCE)."""
    joint = torso.get("joint")
    if joint not in robot.fixed_joints:
        raise MapError(
            f"{path}: the map of arm '{arm}' stands for settings of lift '{joint}' (torso.joint), which the "
            f"preset of '{robot.name}' does not hold (fixed_joints: {', '.join(robot.fixed_joints) or 'none'}); "
            "rebuild the map"
        )
    held = robot.fixed_joints[str(joint)]
    unit = torso.get("unit", "m")
    if abs(float(torso.get("reference", held)) - held) > TCP_TOLERANCE:
        raise MapError(
            f"{path}: the map of arm '{arm}' was built with lift '{joint}' at {torso.get('reference')} {unit} "
            f"(torso.reference), the preset holds it at {held:g} {unit}; rebuild the map"
        )


def _differs(path: Path, arm: str, field: str, stored: object, preset: object) -> NoReturn:
    def show(v: object) -> object:
        return np.round(np.asarray(v, dtype=float), 6).tolist() if isinstance(v, np.ndarray) else v

    raise MapError(
        f"{path}: the map of arm '{arm}' was built for {field} {show(stored)}, the preset has "
        f"{show(preset)}; rebuild the map"
    )
