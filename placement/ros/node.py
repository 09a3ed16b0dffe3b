"""The ROS 2 node ``placement``: one live planner on standard messages (``placement ros serve``).

Topics, relative to the node (``~/x`` is ``/NAMESPACE/placement/x``); QoS is reliable everywhere:

==========================  ==========================================  ==================================
topic                       type                                        QoS, meaning
==========================  ==========================================  ==================================
``/map`` (in)               ``nav_msgs/OccupancyGrid``                  transient local, depth 1 (as Nav2's
                                                                        map server): the base's map
``~/scene`` (in)            ``std_msgs/String``                         volatile, 10: a scene file's text
``~/objects/NAME`` (in)     ``geometry_msgs/PoseStamped``               volatile, 10: object NAME moved
``~/start`` (in)            ``geometry_msgs/PoseStamped``               volatile, 10: the task's start
``/amcl_pose`` (in)         ``geometry_msgs/PoseWithCovarianceStamped`` volatile, 10: the start (AMCL)
``~/reach_goal`` (in)       ``geometry_msgs/PoseStamped``               volatile, 10: a TCP pose to reach
``~/plan`` (out)            ``std_msgs/String``                         transient local, 1: plan document
``~/base_poses`` (out)      ``nav_msgs/Path``                           transient local, 1: base poses
``~/markers`` (out)         ``visualization_msgs/MarkerArray``          transient local, 1: RViz markers
``~/status`` (out)          ``std_msgs/String``                         volatile, 100: one JSON per event
``~/reach_base`` (out)      ``geometry_msgs/PoseStamped``               volatile, 10: the reach answer
``~/plan_now`` (service)    ``std_srvs/Trigger``                        plans; success and a summary
==========================  ==========================================  ==================================

Callbacks only keep the newest message of each input; one worker thread applies what came, in the
order map, scene, start, objects (each change all or nothing, each answered on ``~/status``), plans
once, and publishes. So messages that arrive while it plans are coalesced and the node never falls
behind; a bad message changes nothing and the node goes on.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import rclpy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid
from nav_msgs.msg import Path as PathMsg
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from placement.errors import PlacementError
from placement.planning import PlanResult
from placement.ros.live import LivePlanner, Outcome, first_line
from placement.ros.messages import base_of, base_pose, grid_of, plan_messages, plan_path, stamped_pose
from placement.ros.recording import Recorder, now, recording
from placement.validation import strict_json

log = logging.getLogger(__name__)

NODE_NAME = "placement"
#: [s] how often the graph is scanned for new ``~/objects/NAME`` topics.
SCAN_PERIOD_S = 0.25
OBJECTS = "objects"


def qos(depth: int, latched: bool = False) -> QoSProfile:
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


@dataclass
class Inbox:
    """The newest message of each input since the worker last looked, and when the first came."""

    scene: String | None = None
    grid: OccupancyGrid | None = None
    start: tuple[str, Any] | None = None
    objects: dict[str, PoseStamped] = field(default_factory=dict)
    reach: PoseStamped | None = None
    plan_requested: bool = False
    since: float | None = None  # perf_counter() of the oldest message held

    def empty(self) -> bool:
        return not (self.scene or self.grid or self.start or self.objects or self.reach or self.plan_requested)


@dataclass(frozen=True)
class NodeOptions:
    """What ``placement ros serve`` sets: ``namespace``; ``frame`` the map frame until a ``/map``
    names its own; ``record`` an MCAP file that gets every scene and plan (None: none); ``amcl``:
    AMCL's pose (``/amcl_pose``) moves the start. (How the map's values become occupancy is the
    live planner's :class:`~placement.ros.live.MapPolicy`.)"""

    namespace: str = ""
    frame: str = "map"
    record: Path | None = None
    amcl: bool = True


class PlacementNode:
    """The node around a :class:`~placement.ros.live.LivePlanner` (see the module docstring)."""

    def __init__(self, live: LivePlanner, options: NodeOptions, recorder: Recorder | None = None):
        self.live = live
        self.options = options
        self.frame = options.frame
        self.recorder = recorder
        self.node = Node(NODE_NAME, namespace=options.namespace or None)
        n = self.node
        self.base = n.get_fully_qualified_name()
        self._lock = threading.Lock()  # one change or plan at a time
        self._inbox = Inbox()
        self._wake = threading.Condition()
        self._stopping = False
        self._object_subs: dict[str, Any] = {}
        self._last_summary = "nothing planned yet"
        self._applying_ms = 0.0  # [ms] spent on the changes of the batch being processed
        self.pub_plan = n.create_publisher(String, "~/plan", qos(1, latched=True))
        self.pub_path = n.create_publisher(PathMsg, "~/base_poses", qos(1, latched=True))
        self.pub_markers = n.create_publisher(MarkerArray, "~/markers", qos(1, latched=True))
        self.pub_status = n.create_publisher(String, "~/status", qos(100))
        self.pub_reach = n.create_publisher(PoseStamped, "~/reach_base", qos(10))
        n.create_subscription(OccupancyGrid, "/map", self._keep("grid"), qos(1, latched=True))
        n.create_subscription(String, "~/scene", self._keep("scene"), qos(10))
        n.create_subscription(PoseStamped, "~/start", self._keep_start("~/start"), qos(10))
        if options.amcl:
            n.create_subscription(PoseWithCovarianceStamped, "/amcl_pose", self._keep_start("/amcl_pose"), qos(10))
        n.create_subscription(PoseStamped, "~/reach_goal", self._keep("reach"), qos(10))
        n.create_service(Trigger, "~/plan_now", self._plan_now)
        n.create_timer(SCAN_PERIOD_S, self._scan_objects)
        self._worker = threading.Thread(target=self._work, name="placement-planner", daemon=True)

    # -- inputs ------------------------------------------------------------------------------------------

    def _hold(self, put: Callable[[Inbox], None]) -> None:
        with self._wake:
            put(self._inbox)
            if self._inbox.since is None:
                self._inbox.since = time.perf_counter()
            self._wake.notify()

    def _keep(self, slot: str) -> Callable[[Any], None]:
        return lambda msg: self._hold(lambda box: setattr(box, slot, msg))

    def _keep_start(self, topic: str) -> Callable[[Any], None]:
        return lambda msg: self._hold(lambda box: setattr(box, "start", (topic, msg)))

    def _keep_object(self, name: str) -> Callable[[PoseStamped], None]:
        return lambda msg: self._hold(lambda box: box.objects.__setitem__(name, msg))

    def _subscribe_object(self, name: str) -> None:
        if name in self._object_subs:
            return
        try:
            self._object_subs[name] = self.node.create_subscription(
                PoseStamped, f"~/{OBJECTS}/{name}", self._keep_object(name), qos(10)
            )
        except Exception as exc:  # a name that is no valid topic name: it cannot be moved by topic
            self._object_subs[name] = None
            log.warning("object %r gets no topic: %s", name, first_line(exc))

    def _scan_objects(self) -> None:
        """Subscribe to the scene's objects, and to any ``~/objects/NAME`` someone publishes (an
        unknown name then gets a status line instead of silence)."""
        scene = self.live.scene
        for o in scene.objects if scene is not None else ():
            self._subscribe_object(o.name)
        prefix = f"{self.base.rstrip('/')}/{OBJECTS}/"
        try:
            topics = self.node.get_topic_names_and_types()
        except Exception:
            if self.node.context.ok():
                raise
            return  # a SIGTERM shut the context down while this timer ran: nothing left to subscribe to
        for topic, _types in topics:
            if topic.startswith(prefix) and "/" not in topic[len(prefix) :]:
                self._subscribe_object(topic[len(prefix) :])

    def request_plan(self) -> None:
        """Have the worker plan (and publish) even if nothing changed."""
        self._hold(lambda box: setattr(box, "plan_requested", True))

    def _plan_now(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        with self._wake:
            box, self._inbox = self._inbox, Inbox()
        box.plan_requested = True
        result = self.process(box)
        response.success = result is not None and result.ok
        response.message = self._last_summary
        return response

    # -- the worker ----------------------------------------------------------------------------------------

    def start(self) -> None:
        self._worker.start()

    def stop(self) -> None:
        with self._wake:
            self._stopping = True
            self._wake.notify()
        if self._worker.is_alive():
            self._worker.join(timeout=30)

    def _work(self) -> None:
        while True:
            with self._wake:
                while self._inbox.empty() and not self._stopping:
                    self._wake.wait()
                if self._stopping:
                    return
                box, self._inbox = self._inbox, Inbox()
            try:
                self.process(box)
            except Exception as exc:  # never let one bad event stop the node
                if self._stopping:  # the context is going away under the event: nothing to say it on
                    return
                log.exception("unexpected error")
                self.status({"source": "node", "status": "error", "error": first_line(exc)})

    def status(self, doc: dict[str, Any]) -> None:
        text = strict_json(doc, PlacementError, None)
        self.pub_status.publish(String(data=text))
        log.info("%s", text)

    def _outcome(self, source: str, apply: Callable[[], Outcome]) -> bool:
        t = time.perf_counter()
        try:
            outcome = apply()
        except PlacementError as exc:  # the message itself was refused before it reached the planner
            outcome = Outcome(source, "refused", first_line(exc))
        except Exception as exc:  # a defect of ours: said on ~/status for this source, the node goes on
            log.exception("unexpected error on %s", source)
            outcome = Outcome(source, "refused", f"internal error: {first_line(exc)}")
        self.status(outcome.to_json())
        self._applying_ms += (time.perf_counter() - t) * 1e3
        return outcome.applied

    def process(self, box: Inbox) -> PlanResult | None:
        """Apply what ``box`` holds, plan if anything changed (or a plan was asked for), publish;
        answer a reach question. Returns the new plan, if one was made."""
        with self._lock:
            changed = False
            self._applying_ms = 0.0
            if box.grid is not None:
                grid = box.grid
                changed |= self._outcome("/map", lambda: self._set_map(grid))
            if box.scene is not None:
                text = box.scene.data
                applied = self._outcome(f"{self.base}/scene", lambda: self.live.set_scene(text, f"{self.base}/scene"))
                changed |= applied
                if applied and self.recorder is not None:
                    self.recorder.write(f"{self.base}/scene", box.scene)
            if box.start is not None:
                topic, msg = box.start
                source = f"{self.base}/start" if topic == "~/start" else topic
                changed |= self._outcome(
                    source, lambda: self.live.move_start(*base_of(msg, self.frame, source), source)
                )
            for name, msg in box.objects.items():
                changed |= self._outcome(f"{self.base}/{OBJECTS}/{name}", functools.partial(self._move, name, msg))
            result = None
            if changed or box.plan_requested:
                result = self._plan(box.since)
            if box.reach is not None:
                self._reach(box.reach)
            return result

    def _set_map(self, grid: OccupancyGrid) -> Outcome:
        outcome = self.live.set_map(grid_of(grid, None))
        if outcome.applied:
            self.frame = grid.header.frame_id.lstrip("/")
            if self.recorder is not None:
                self.recorder.write("/map", grid)
        return outcome

    def _move(self, name: str, msg: PoseStamped) -> Outcome:
        source = f"{self.base}/{OBJECTS}/{name}"
        position, q = stamped_pose(msg, self.frame, source)
        return self.live.move_object(name, position, q, source)

    def _plan(self, since: float | None) -> PlanResult | None:
        t0 = time.perf_counter()
        try:
            result = self.live.plan()
        except PlacementError as exc:
            self._last_summary = f"not planned: {first_line(exc)}"
            self.status({"source": "plan", "status": "failed", "error": first_line(exc)})
            return None
        planned = time.perf_counter()
        planner = self.live.planner
        assert planner is not None  # it planned
        stamp = now()
        path = plan_path(result, self.frame, stamp)  # first: what Nav2 waits for
        self.pub_path.publish(path)
        published = time.perf_counter()
        msgs = plan_messages(result, planner.scene, planner.robot, self.frame, stamp, path)
        self.pub_plan.publish(msgs["plan"])
        self.pub_markers.publish(msgs["markers"])
        if self.recorder is not None:
            for key, msg in msgs.items():
                self.recorder.write(f"{self.base}/{key}", msg)
        self._last_summary = summary(result)
        timings = {
            "apply": self._applying_ms,
            "plan": (planned - t0) * 1e3,
            "publish": (time.perf_counter() - planned) * 1e3,
        }
        if since is not None:
            timings["message_to_path"] = (published - since) * 1e3
        self.status(
            {
                "source": "plan",
                "status": "planned" if result.ok else "infeasible",
                "summary": self._last_summary,
                "steps": len(result.steps),
                "planned": sum(s.ok for s in result.steps),
                "timings_ms": {k: round(v, 3) for k, v in timings.items()},
            }
        )
        return result

    def _reach(self, goal: PoseStamped) -> None:
        source = f"{self.base}/reach_goal"
        t = time.perf_counter()
        try:
            position, q = stamped_pose(goal, self.frame, source)
            step = self.live.reach(position, q)
        except PlacementError as exc:
            self.status({"source": source, "status": "refused", "error": first_line(exc)})
            return
        ms = round((time.perf_counter() - t) * 1e3, 3)
        if not step.ok or step.base is None:
            self.status({"source": source, "status": "unreachable", "error": step.reason, "timings_ms": {"total": ms}})
            return
        self.pub_reach.publish(base_pose(step.base, self.frame, now()))
        self.status(
            {
                "source": source,
                "status": "answered",
                "base": [round(float(v), 6) for v in step.base],
                "arm": step.arm,
                "joints": {k: float(v) for k, v in step.joints.items()},
                "timings_ms": {"total": ms},
            }
        )


def summary(result: PlanResult) -> str:
    """One line: how many steps planned, and the first failing step's reason."""
    bad = result.failed_step
    done = sum(s.ok for s in result.steps)
    if bad is None:
        travel = sum(s.travel_time_s for s in result.steps if s.ok)
        task = None if result.certificate is None else result.certificate.task_time_s
        head = f"planned {done} of {len(result.steps)} steps"
        return (
            f"{head}, task {task:.1f} s, base travel {travel:.1f} s"
            if task is not None
            else f"{head}, base travel {travel:.1f} s"
        )
    return f"planned {done} of {len(result.steps)} steps; step {bad.step} ({bad.action} {bad.target}) is infeasible: {bad.reason}"


def serve(live: LivePlanner, options: NodeOptions, ready: Callable[[str], None] | None = None) -> None:
    """Run the node until SIGINT or SIGTERM (rclpy's handlers); ``ready`` gets its name once spinning."""
    rclpy.init()
    try:
        with contextlib.ExitStack() as stack:
            recorder = stack.enter_context(recording(options.record)) if options.record is not None else None
            node = PlacementNode(live, options, recorder)
            node.start()
            if live.scene is not None:
                node.request_plan()
            if ready is not None:
                ready(node.base)
            try:
                rclpy.spin(node.node)
            except (
                KeyboardInterrupt,
                rclpy.executors.ExternalShutdownException,
                # a SIGTERM that lands while the executor waits on a busy machine: shut down the same
                rclpy.executors.ShutdownException,
            ):
                pass
            finally:
                node.stop()
                node.node.destroy_node()
    finally:
        if rclpy.ok():
            rclpy.shutdown()
