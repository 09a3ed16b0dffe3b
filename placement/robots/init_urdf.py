"""Reading a robot description for ``placement robots init``: a URDF, or a ``.xacro`` expanded with the
``xacro`` package (also used when a preset names a ``.xacro`` in ``urdf:``).

Every failure is one :class:`RobotError` line naming the file: a missing file, a file that is not
URDF XML, a xacro error (undefined macro or property, ``$(find ...)`` without ROS).
"""

from __future__ import annotations

import contextlib
import io
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import pinocchio as pin

from ..errors import RobotError
from ..validation import one_line

#: Suffixes expanded with xacro.
XACRO_SUFFIXES = (".xacro",)


def is_xacro(path: Path) -> bool:
    """Whether ``path`` names a xacro file (``robot.urdf.xacro``, ``robot.xacro``)."""
    return Path(path).suffix.lower() in XACRO_SUFFIXES


def expand_xacro(path: Path, where: str) -> bytes:
    """The URDF text [UTF-8 bytes] of the xacro file ``path``; ``where`` starts every error line."""
    try:
        import xacro
    except ImportError:
        raise RobotError(f"{where}: {path} is a xacro file; expanding it needs the xacro package "
                         "(pip install xacro)") from None
    if not Path(path).is_file():
        raise RobotError(f"{where}: xacro file not found: {path}")
    # xacro prints its own diagnostics and may call sys.exit: both are turned into one error line
    sink = io.StringIO()
    try:
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            doc = xacro.process_file(str(path))
        text = doc.toxml()
    except (Exception, SystemExit) as exc:  # XacroException, XML errors, a missing include, sys.exit
        msg = " ".join(str(exc).split()) or " ".join(sink.getvalue().split())[:200] or type(exc).__name__
        raise RobotError(one_line(f"{where}: xacro {path} does not expand: {msg}")) from None
    return text.encode("utf-8")


def read_description(path: Path, where: str) -> bytes:
    """The URDF bytes of ``path``: the file itself, or the expansion of a ``.xacro``."""
    path = Path(path)
    if is_xacro(path):
        return expand_xacro(path, where)
    try:
        return path.read_bytes()
    except OSError as exc:
        raise RobotError(one_line(f"{where}: cannot read {path}: {exc.strerror or exc}")) from None


def mimic_joints(xml: bytes | str) -> dict[str, str]:
    """{mimic joint: the joint it follows} of a URDF document ({} if it is not parseable XML)."""
    try:
        root = ET.fromstring(xml)
    except ET.ParseError:
        return {}
    return {j.get("name"): j.find("mimic").get("joint", "?") for j in root.iter("joint")
            if j.find("mimic") is not None}


@dataclass
class Description:
    """A parsed robot description.

    Attributes:
        path: the file given (URDF or xacro).
        xml: the URDF text (expanded for xacro).
        model: its pinocchio model (fixed base).
        mimic: {mimic joint: leader}.
    """

    path: Path
    xml: str
    model: pin.Model
    mimic: dict[str, str]


def load_description(path: str | Path) -> Description:
    """Read and parse a URDF or xacro file (a path, or ``package://example-robot-data/...``); one-line
    :class:`RobotError` for anything unusable."""
    if str(path).startswith("package://"):
        from .spec import resolve_path

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
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise RobotError(one_line(f"{where}: not a URDF: not XML ({exc})")) from None
    if root.tag != "robot":
        raise RobotError(f"{where}: not a URDF: the root element is <{root.tag}>, not <robot>")
    try:
        model = pin.buildModelFromXML(text)
    except Exception as exc:  # pinocchio raises plain RuntimeError/ValueError
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise RobotError(one_line(f"{where}: URDF does not load: {msg}")) from None
    return Description(path, text, model, mimic_joints(data))
