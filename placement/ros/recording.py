"""MCAP recordings of scenes and plans as ROS 2 messages, for Foxglove and ``ros2 bag play``.

A recording holds, on the topics the node publishes (``/placement/...``): the scene file's text
(``scene``, ``std_msgs/String``), the plan document (``plan``, ``std_msgs/String``, as ``placement
query --json`` writes it), the base poses (``base_poses``, ``nav_msgs/Path``) and the markers
(``markers``, ``visualization_msgs/MarkerArray``), and the scene's occupancy map on ``/map``
(``nav_msgs/OccupancyGrid``, occupied 100, free 0) when it has one. Messages are serialised by
rclpy itself (CDR) with their ``ros2msg`` schemas, read from the message packages' ``.msg`` files.
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import sysconfig
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any, cast

from builtin_interfaces.msg import Time
from mcap.writer import Writer
from rclpy.serialization import serialize_message

from placement.errors import PlacementError

#: The primitive field types of ROS 2 message definitions (no schema of their own).
PRIMITIVES = frozenset(
    "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 string wstring".split()
)
#: The separator between a schema's definitions (as rosbag2 writes it).
SEPARATOR = "=" * 80


def message_type(msg: Any) -> str:
    """``pkg/msg/Type`` of a message instance."""
    cls = type(msg)
    return f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"


def _definition_file(pkg: str, name: str) -> Path:
    path = Path(sysconfig.get_path("data")) / "share" / pkg / "msg" / f"{name}.msg"
    if not path.is_file():
        raise PlacementError(f"the definition of {pkg}/msg/{name} is not installed (looked for {path})")
    return path


def _field_types(text: str, pkg: str) -> list[tuple[str, str]]:
    """(package, type) of every non-primitive field of a definition, in order."""
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        kind, _, rest = line.partition(" ")
        if re.match(r"^\w+\s*=", rest):  # a constant
            continue
        kind = re.sub(r"\[.*\]$", "", kind)
        kind = kind.split("<=", 1)[0]
        if kind in PRIMITIVES:
            continue
        if "/" in kind:
            parts = kind.split("/")
            out.append((parts[0], parts[-1]))
        elif kind == "Header":
            out.append(("std_msgs", "Header"))
        else:
            out.append((pkg, kind))
    return out


def schema_text(datatype: str) -> str:
    """The ``ros2msg`` schema of ``pkg/msg/Type``: its definition, then each type it uses once,
    depth first, each after a separator line and ``MSG: pkg/Type``."""
    pkg, _, name = datatype.split("/")
    main = _definition_file(pkg, name).read_text()
    parts = [main.rstrip("\n")]
    seen = {(pkg, name)}
    todo = _field_types(main, pkg)
    while todo:
        dep = todo.pop(0)
        if dep in seen:
            continue
        seen.add(dep)
        text = _definition_file(*dep).read_text()
        parts.append(f"{SEPARATOR}\nMSG: {dep[0]}/{dep[1]}\n{text.rstrip(chr(10))}")
        todo = _field_types(text, dep[0]) + todo
    return "\n".join(parts) + "\n"


def now() -> Time:
    """The wall clock as a ROS time stamp."""
    ns = time.time_ns()
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


class Recorder:
    """Writes messages to an MCAP file, one channel per topic (:meth:`write`), closed by :meth:`close`."""

    def __init__(self, stream: IO[bytes]):
        self._writer = Writer(stream)
        self._writer.start(profile="ros2", library="placement")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence = 0

    def write(self, topic: str, msg: Any, log_time_ns: int | None = None) -> None:
        """Record ``msg`` on ``topic`` at ``log_time_ns`` [ns since the epoch] (default now)."""
        datatype = message_type(msg)
        if datatype not in self._schemas:
            self._schemas[datatype] = self._writer.register_schema(
                name=datatype, encoding="ros2msg", data=schema_text(datatype).encode()
            )
        if topic not in self._channels:
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="cdr", schema_id=self._schemas[datatype]
            )
        t = time.time_ns() if log_time_ns is None else log_time_ns
        self._sequence += 1
        self._writer.add_message(
            self._channels[topic], log_time=t, data=serialize_message(msg), publish_time=t, sequence=self._sequence
        )

    def close(self) -> None:
        cast("Callable[[], None]", self._writer.finish)()  # (mcap leaves Writer.finish unannotated)


@contextlib.contextmanager
def recording(path: str | Path) -> Iterator[Recorder]:
    """A :class:`Recorder` writing ``path`` whole or not at all: a temporary file beside it, moved
    onto it when the block ends without error."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        fh = open(tmp, "xb")
    except OSError as exc:
        raise PlacementError(f"--mcap {path}: cannot write there ({exc.strerror or exc})") from None
    try:
        with fh:
            rec = Recorder(fh)
            yield rec
            rec.close()
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


#: The topics of a recorded plan: the node's, with the node at the root namespace.
PLAN_TOPICS = "/placement"


def record_plan(path: str | Path, scene_text: str, result: Any, planner: Any, frame: str = "map") -> Path:
    """Write an MCAP file of one query: the scene file's text, its occupancy map (if any), and the
    plan's messages (see :func:`placement.ros.messages.plan_messages`), all stamped now."""
    from std_msgs.msg import String

    from placement.ros.messages import occupancy_grid, plan_messages

    stamp = now()
    with recording(path) as rec:
        rec.write(f"{PLAN_TOPICS}/scene", String(data=scene_text))
        if planner.scene.occupancy is not None:
            rec.write("/map", occupancy_grid(planner.scene.occupancy, frame, stamp))
        for key, msg in plan_messages(result, planner.scene, planner.robot, frame, stamp).items():
            rec.write(f"{PLAN_TOPICS}/{key}", msg)
    return Path(path)
