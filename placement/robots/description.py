"""Reading a robot description: a URDF file, or a ``.xacro`` expanded with the ``xacro`` package in a
bounded child process (a preset may name either in ``urdf:``; ``placement robots init`` reads them too).

Every failure is one :class:`RobotError` line naming the file: a missing file, a file that is not
URDF XML, a xacro error (undefined macro or property, ``$(find ...)`` without ROS).
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from placement.errors import RobotError
from placement.validation import one_line, read_regular

#: Suffixes expanded with xacro.
XACRO_SUFFIXES = (".xacro",)


def is_xacro(path: Path) -> bool:
    """Whether ``path`` names a xacro file (``robot.urdf.xacro``, ``robot.xacro``)."""
    return Path(path).suffix.lower() in XACRO_SUFFIXES


#: Bounds of a xacro expansion, which runs arbitrary expressions (``${9**9**9}``) and can double a
#: property until memory runs out: it runs in a child process with this much time [s] and address
#: space [bytes], and its URDF may be at most :data:`MAX_URDF_BYTES`.
XACRO_TIMEOUT = 30.0
XACRO_MEMORY = 2**30
#: Largest URDF read or produced by xacro [bytes].
MAX_URDF_BYTES = 64 * 2**20
#: Largest xacro file read [bytes] (its includes are bounded by the child's time and memory).
MAX_XACRO_BYTES = 16 * 2**20

_XACRO_CHILD = r"""
import contextlib, io, os, sys
path, limit, folders = sys.argv[1], int(sys.argv[2]), [f for f in sys.argv[3].split(os.pathsep) if f]
missing = []  # what $(find) could not resolve: said alone (xacro repeats it in its own words)
try:
    import xacro
except ImportError:
    sys.exit(4)
try:  # $(find PKG) without a sourced ROS 2: the package folders package:// paths resolve in
    import ament_index_python.packages as index

    _share = index.get_package_share_directory

    def _found(pkg, *args, **kwargs):
        try:
            return _share(pkg, *args, **kwargs)
        except Exception:
            pass
        for folder in folders:
            if os.path.isdir(os.path.join(folder, pkg)):
                return os.path.join(folder, pkg)
        missing.append(
            f"$(find {pkg}): package '{pkg}' not found in AMENT_PREFIX_PATH, ROS_PACKAGE_PATH or a folder "
            "above the file; put it beside the robot's package or add its parent folder to ROS_PACKAGE_PATH"
        )
        raise LookupError(missing[-1])

    index.get_package_share_directory = _found
except ImportError:
    pass
sink = io.StringIO()
try:
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        text = xacro.process_file(path).toxml()
except MemoryError:
    sys.stderr.write("out of memory")
    sys.exit(3)
except (Exception, SystemExit) as exc:
    msg = missing[-1] if missing else None
    msg = msg or " ".join(str(exc).split()) or " ".join(sink.getvalue().split())[:200] or type(exc).__name__
    sys.stderr.write(msg[:1000])
    sys.exit(3)
data = text.encode("utf-8")
if len(data) > limit:
    sys.stderr.write(f"the URDF it gives is {len(data)} bytes, more than the {limit} allowed")
    sys.exit(3)
sys.stdout.buffer.write(data)
"""


def _limit_child() -> None:  # runs in the child before exec
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (XACRO_MEMORY, XACRO_MEMORY))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def expand_xacro(path: Path, where: str) -> bytes:
    """The URDF text [UTF-8 bytes] of the xacro file ``path``; ``where`` starts every error line.

    xacro runs in a child process bounded by :data:`XACRO_TIMEOUT` and :data:`XACRO_MEMORY`. A
    ``$(find PKG)`` resolves as in a sourced ROS 2 workspace, else to the first ``FOLDER/PKG`` of
    :func:`package_dirs` (a vendor's package beside its dependencies, no ROS needed)."""
    if importlib.util.find_spec("xacro") is None:
        raise RobotError(f"{where}: {path} is a xacro file; expanding it needs the xacro package (pip install xacro)")
    if not Path(path).is_file():
        raise RobotError(f"{where}: xacro file not found: {path}")
    read_regular(path, RobotError, f"{where}: {path}", MAX_XACRO_BYTES, "xacro file")  # no FIFO, no device
    try:
        run = subprocess.run(
            [
                sys.executable,
                "-c",
                _XACRO_CHILD,
                os.fspath(Path(path).resolve()),
                str(MAX_URDF_BYTES),
                os.pathsep.join(package_dirs(path)),
            ],
            stdin=subprocess.DEVNULL,
            capture_output=True,
            timeout=XACRO_TIMEOUT,
            preexec_fn=_limit_child if os.name == "posix" else None,
            cwd=Path(path).parent,
        )
    except subprocess.TimeoutExpired:
        raise RobotError(
            f"{where}: xacro {path} does not expand within {XACRO_TIMEOUT:g} s (an endless or huge expansion?)"
        ) from None
    if run.returncode != 0:
        msg = " ".join(run.stderr.decode("utf-8", "replace").split())
        msg = msg if len(msg) <= 300 else msg[:150] + " ... " + msg[-140:]
        if run.returncode == 3 and msg == "out of memory" or not msg:
            msg = (
                f"it needs more than {XACRO_MEMORY / 2**30:g} GiB of memory"
                if run.returncode in (3, 1)
                else f"xacro stopped with exit code {run.returncode}"
            )
        raise RobotError(one_line(f"{where}: xacro {path} does not expand: {msg}"))
    return run.stdout


#: Bounds of a robot's kinematic tree, checked before pinocchio parses it (urdfdom and pinocchio
#: recurse once per joint: a 5,000-deep chain of fixed joints overflowed the C++ stack, 20,000 links ran
#: for minutes). Real robots have tens to a few hundred links.
MAX_LINKS = 2_000
MAX_DEPTH = 500
#: Joints that move (every type but ``fixed``): pinocchio's data holds tensors of their number cubed
#: (a 500-joint chain: 1 GB per ``createData``, 83 s and 16 GB to propose a preset; 256: 16 s and
#: 2.3 GB). Humanoids with two dexterous hands have about a hundred.
MAX_MOVING_JOINTS = 256
#: [m] the farthest a joint origin may be from its parent link (a real one is within metres).
MAX_OFFSET = 1e4


def _check_numbers(element: ET.Element, where: str, fields: tuple[tuple[str, str, int], ...]) -> None:
    """RobotError unless each (child tag, attribute, count) of ``element`` that is present holds that
    many numbers (urdfdom refuses the whole file otherwise, with C++ errors naming no file)."""
    for tag, attr, count in fields:
        child = element.find(tag)
        text = None if child is None else child.get(attr)
        if text is None:
            continue
        try:
            ok = len([float(v) for v in text.split()]) == count
        except ValueError:
            ok = False
        if not ok:
            what = "a number" if count == 1 else f"{count} numbers"
            raise RobotError(f"{where}: {tag} {attr} {text[:60]!r} is not {what}")


def check_tree(root: ET.Element, where: str) -> None:
    """RobotError (one line naming ``where``) unless the URDF ``root`` (<robot>) has at most
    :data:`MAX_LINKS` links and :data:`MAX_MOVING_JOINTS` moving joints, no chain deeper than
    :data:`MAX_DEPTH` joints, finite joint origins within :data:`MAX_OFFSET` of their parents, and
    numbers where the URDF format has them (joint origins, axes and limits, inertials)."""
    links = root.findall("link")
    if len(links) > MAX_LINKS:
        raise RobotError(f"{where}: {len(links):,} links, more than the {MAX_LINKS:,} a robot may have")
    moving = sum(1 for j in root.findall("joint") if j.get("type", "fixed") != "fixed")
    if moving > MAX_MOVING_JOINTS:
        raise RobotError(
            f"{where}: {moving:,} moving (non-fixed) joints, more than the {MAX_MOVING_JOINTS} a robot may have"
        )
    parent: dict[str, str] = {}
    for j in root.findall("joint"):
        name = str(j.get("name", "?"))[:60]
        p, c = j.find("parent"), j.find("child")
        if p is not None and c is not None and p.get("link") and c.get("link"):
            parent[str(c.get("link"))] = str(p.get("link"))
        origin = j.find("origin")
        text = origin.get("xyz", "0 0 0") if origin is not None else "0 0 0"
        try:
            xyz = [float(v) for v in text.split()]
        except ValueError:
            raise RobotError(f"{where}: joint {name!r}: origin xyz {text[:60]!r} is not three numbers") from None
        if len(xyz) != 3 or not all(abs(v) <= MAX_OFFSET for v in xyz):  # NaN fails too
            raise RobotError(
                f"{where}: joint {name!r}: origin xyz {text[:60]!r} is not three finite numbers within "
                f"+-{MAX_OFFSET:g} m of its parent link"
            )
        _check_numbers(j, f"{where}: joint {name!r}", (("origin", "rpy", 3), ("axis", "xyz", 3)))
        limit = j.find("limit")
        for attr in ("lower", "upper", "effort", "velocity"):
            if limit is not None and limit.get(attr) is not None:
                _check_numbers(j, f"{where}: joint {name!r}", (("limit", attr, 1),))
    for element in links:
        inertial = element.find("inertial")
        if inertial is not None:
            lname = f"{where}: link {str(element.get('name', '?'))[:60]!r}: inertial"
            _check_numbers(inertial, lname, (("origin", "xyz", 3), ("origin", "rpy", 3), ("mass", "value", 1)))
            _check_numbers(
                inertial, lname, tuple(("inertia", a, 1) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
            )
    depth: dict[str, int] = {}
    for link in parent:
        chain: list[str] = []
        node = link
        while node in parent and node not in depth and len(chain) <= MAX_DEPTH + 1:
            chain.append(node)
            node = parent[node]
        base = depth.get(node, 0)
        for k, n in enumerate(reversed(chain)):
            depth[n] = base + k + 1
        if depth.get(link, len(chain)) > MAX_DEPTH or len(chain) > MAX_DEPTH:
            raise RobotError(
                f"{where}: a chain of more than {MAX_DEPTH:,} joints (to link {link[:60]!r}); a robot's tree "
                "may be at most that deep"
            )


def read_description(path: Path, where: str) -> bytes:
    """The URDF bytes of ``path``: the file itself, or the expansion of a ``.xacro``."""
    path = Path(path)
    if is_xacro(path):
        return expand_xacro(path, where)
    return read_regular(path, RobotError, where, MAX_URDF_BYTES, "URDF")


def kinematic_xml(root: ET.Element) -> str:
    """The URDF ``root`` (<robot>) as text without its ``<visual>`` and ``<collision>`` elements: what
    the kinematic model is built from. The shapes are read (and screened) on their own; urdfdom
    prints a C++ error on stderr for every shape it cannot parse (a NaN mesh scale), which the
    model does not need."""
    bare = ET.fromstring(ET.tostring(root))
    for link in bare.iter("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    return ET.tostring(bare, encoding="unicode")


def package_dirs(urdf: Path | str, extra: Sequence[Path | str] = ()) -> list[str]:
    """The folders where a ``package://NAME/...`` path of ``urdf`` may resolve (as ``FOLDER/NAME/...``),
    in the order they are searched: ``extra``; every folder of ``ROS_PACKAGE_PATH`` and its parent;
    the ``share`` folder of every prefix of ``AMENT_PREFIX_PATH`` (a sourced ROS 2 workspace);
    example-robot-data's ``share`` (when installed); every ancestor of the URDF's folder (a package's
    own folder sits a few levels above its URDF, in a ROS package and in a Python package alike)."""
    out: list[str] = [str(p) for p in extra]
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            out += [entry, str(Path(entry).parent)]
    out += [str(Path(p) / "share") for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    try:
        from placement.robots.spec import share_dir

        out.append(str(share_dir()))
    except Exception:  # example-robot-data is not installed
        pass
    out += [str(p) for p in Path(urdf).resolve().parents]
    return list(dict.fromkeys(out))


#: A vector attribute written with commas: ``rpy="1.5707963, 1.3089969 1.5707963"`` (in the ARMAR-6
#: URDF of its maker's ``armar`` package). urdfdom refuses the whole file over it; read as meant.
_COMMA_VECTOR = re.compile(r'\b(xyz|rpy)="([^"]*,[^"]*)"')


def readable_urdf(text: str) -> tuple[str, list[str]]:
    """(``text`` with each ``xyz``/``rpy`` vector written with commas rewritten with spaces when it then
    holds three numbers, one note per rewrite naming it); every other byte as it was."""
    notes: list[str] = []

    def fix(m: re.Match[str]) -> str:
        spaced = " ".join(m.group(2).replace(",", " ").split())
        try:
            ok = len([float(v) for v in spaced.split()]) == 3
        except ValueError:
            ok = False
        if not ok:
            return m.group(0)
        notes.append(f"{m.group(1)} {m.group(2)[:60]!r} is read as '{spaced}' (a URDF vector is separated by spaces)")
        return f'{m.group(1)}="{spaced}"'

    return _COMMA_VECTOR.sub(fix, text), notes
