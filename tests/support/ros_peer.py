"""A real ROS 2 peer for the node's tests: ``placement ros serve`` in a subprocess, a test node here.

Both are isolated from any other ROS 2 system (and from other test runs) by a random
``ROS_DOMAIN_ID`` and localhost-only discovery.
"""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import OccupancyGrid, Path
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from placement.ros.node import qos

#: History depth of the peer's readers of the node's latched topics. The node keeps one message
#: (depth 1, as a latched topic should), but a reader's own history holds what arrived while the
#: test did not spin (e.g. while it planned the same scene itself to compare): with a depth of 1
#: two plans in that time were one, and the tests that count plans waited for one that never came.
KEPT = 100

#: Longest wait [s] for the node to start or to answer. A wait ends as soon as what it waits for
#: arrives: the bound only matters on a machine so loaded that the node's first planner (maps read,
#: IK warmed) takes minutes, where a shorter one failed tests that would have passed.
WAIT_S = 180.0

#: ROS 2 environment of both sides: discovery on this machine only.
LOCAL = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_LOCALHOST_ONLY": "1"}


def ros_env() -> dict[str, str]:
    """A random domain (1..200) with localhost discovery, for the node's subprocess and this process."""
    return {**LOCAL, "ROS_DOMAIN_ID": str(random.SystemRandom().randint(1, 200))}


class NodeProcess:
    """``placement ros serve ARGS`` as a subprocess; :meth:`ready` waits for its "ready" line."""

    def __init__(self, args: list[str], env: dict[str, str]):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "placement.cli.main", "ros", "serve", *args],
            stderr=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, **env},
        )
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.append(line.rstrip("\n"))

    def ready(self, timeout: float = WAIT_S) -> float:
        """Seconds until the node said it is ready (AssertionError with its stderr if it did not)."""
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < timeout:
            if any("ready" in ln for ln in self.lines):
                return time.perf_counter() - t0
            if self.proc.poll() is not None:
                break
            time.sleep(0.02)
        raise AssertionError("the node did not start:\n" + "\n".join(self.lines))

    def stop(self) -> int:
        self.proc.terminate()
        try:
            return self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()


class Peer:
    """A test node that talks to the node ``/placement``: publishers of its inputs, what it
    publishes collected in lists (``status`` as parsed JSON), and :meth:`plan_now`."""

    def __init__(self, domain: int, base: str = "/placement"):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node("placement_test_peer", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.base = base
        self.status: list[dict[str, Any]] = []
        self.plans: list[dict[str, Any]] = []
        self.paths: list[Path] = []
        self.markers: list[MarkerArray] = []
        self.reach: list[PoseStamped] = []
        n = self.node
        n.create_subscription(String, f"{base}/status", lambda m: self.status.append(json.loads(m.data)), qos(100))
        n.create_subscription(String, f"{base}/plan", lambda m: self.plans.append(json.loads(m.data)), qos(KEPT, True))
        n.create_subscription(Path, f"{base}/base_poses", self.paths.append, qos(KEPT, True))
        n.create_subscription(MarkerArray, f"{base}/markers", self.markers.append, qos(KEPT, True))
        n.create_subscription(PoseStamped, f"{base}/reach_base", self.reach.append, qos(10))
        self.map = n.create_publisher(OccupancyGrid, "/map", qos(1, True))
        self.scene = n.create_publisher(String, f"{base}/scene", qos(10))
        self.start = n.create_publisher(PoseStamped, f"{base}/start", qos(10))
        self.amcl = n.create_publisher(PoseWithCovarianceStamped, "/amcl_pose", qos(10))
        self.reach_goal = n.create_publisher(PoseStamped, f"{base}/reach_goal", qos(10))
        self._objects: dict[str, Any] = {}
        self.trigger = n.create_client(Trigger, f"{base}/plan_now")

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)

    def spin_until(self, cond: Callable[[], Any], timeout: float = WAIT_S) -> Any:
        end = time.perf_counter() + timeout
        while time.perf_counter() < end:
            if cond():
                return cond()
            self.executor.spin_once(timeout_sec=0.02)
        return cond()

    def connected(self, publisher: Any, timeout: float = WAIT_S) -> None:
        assert self.spin_until(lambda: publisher.get_subscription_count() > 0, timeout), "the node never subscribed"

    def object(self, name: str) -> Any:
        """The publisher of ``~/objects/NAME``, connected."""
        if name not in self._objects:
            self._objects[name] = self.node.create_publisher(PoseStamped, f"{self.base}/objects/{name}", qos(10))
            self.connected(self._objects[name])
        return self._objects[name]

    def statuses(self, source: str) -> list[dict[str, Any]]:
        return [s for s in self.status if s["source"] == source]

    def publish_and_wait(self, publish: Callable[[], None], source: str, timeout: float = WAIT_S) -> dict[str, Any]:
        """Publish, then wait for the next status line from ``source``; when it is applied, also for
        the plan it leads to (its status line and the plan, path and markers). Returns the status line."""
        before = len(self.statuses(source))
        plans = len(self.statuses("plan"))
        publish()
        assert self.spin_until(lambda: len(self.statuses(source)) > before, timeout), f"no status from {source}"
        line = self.statuses(source)[before]
        if line["status"] == "applied":
            self.wait_plan(plans, timeout)
        return line

    def wait_plan(self, plans_before: int, timeout: float = WAIT_S) -> dict[str, Any]:
        """Wait for the plan after ``plans_before`` plan status lines, and its messages."""
        assert self.spin_until(lambda: len(self.statuses("plan")) > plans_before, timeout), "no plan"
        status = self.statuses("plan")[plans_before]
        if status["status"] in ("planned", "infeasible"):
            n = sum(s["status"] in ("planned", "infeasible") for s in self.statuses("plan")[: plans_before + 1])
            assert self.spin_until(lambda: min(len(self.plans), len(self.paths), len(self.markers)) >= n, timeout)
        return status

    def plan_now(self, timeout: float = WAIT_S) -> Trigger.Response:
        assert self.trigger.wait_for_service(timeout_sec=timeout)
        future = self.trigger.call_async(Trigger.Request())
        assert self.spin_until(future.done, timeout), "plan_now did not answer"
        return future.result()
