"""Reading a robot description for ``placement robots init``: a URDF, or a ``.xacro`` expanded with the
``xacro`` package (also used when a preset names a ``.xacro`` in ``urdf:``).

Every failure is one :class:`RobotError` line naming the file: a missing file, a file that is not
URDF XML, a xacro error (undefined macro or property, ``$(find ...)`` without ROS).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import pinocchio as pin

from placement.errors import RobotError
from placement.robots.description import check_tree, kinematic_xml, read_description, readable_urdf
from placement.robots.model_cache import mimic_joints
from placement.validation import one_line


#: Suffixes expanded with xacro.
@dataclass
class Description:
    """A parsed robot description.

    Attributes:
        path: the file given (URDF or xacro).
        xml: the URDF text (expanded for xacro).
        model: its pinocchio model (fixed base).
        mimic: {mimic joint: leader}.
        notes: what was read other than as written (see
            :func:`~placement.robots.description.readable_urdf`), for warnings.
    """

    path: Path
    xml: str
    model: pin.Model
    mimic: dict[str, str]
    notes: list[str] = field(default_factory=list)


def load_description(path: str | Path) -> Description:
    """Read and parse a URDF or xacro file (a path, or ``package://example-robot-data/...``); one-line
    :class:`RobotError` for anything unusable."""
    if str(path).startswith("package://"):
        from placement.robots.spec import resolve_path

        try:
            path = resolve_path(str(path), Path.cwd())
        except Exception:  # example-robot-data is not installed
            raise RobotError(f"{path}: needs the example-robot-data package, which is not installed") from None
    path = Path(path).expanduser()
    where = str(path)
    if not path.exists():
        raise RobotError(f"{where}: file not found")
    if not path.is_file():
        raise RobotError(f"{where}: not a file (give a .urdf or .xacro file)")
    data = read_description(path, where)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RobotError(f"{where}: not a URDF: not UTF-8 text (byte {exc.start})") from None
    text, notes = readable_urdf(text)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise RobotError(one_line(f"{where}: not a URDF: not XML ({exc})")) from None
    if root.tag != "robot":
        raise RobotError(f"{where}: not a URDF: the root element is <{root.tag}>, not <robot>")
    check_tree(root, where)
    try:
        model = pin.buildModelFromXML(kinematic_xml(root))
    except Exception as exc:  # pinocchio raises plain RuntimeError/ValueError
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise RobotError(one_line(f"{where}: URDF does not load: {msg}")) from None
    return Description(path, text, model, mimic_joints(data), [f"{where}: {n}" for n in notes])
