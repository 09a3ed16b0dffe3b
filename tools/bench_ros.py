"""The ROS 2 node's latency: from a message arriving to the new base poses being published, per change.

`placement ros serve` runs as a subprocess; a test peer (tests/support/ros_peer.py: rclpy, Fast DDS,
a random domain, localhost discovery) publishes the WRS arena's map and tidy-up scene, then changes
one thing at a time, alternating between two values: an object moved, the start moved, the map with and
without a crate, the whole scene sent again with one object elsewhere. For each kind of change the
node's own status line gives the planning time (applying the change and planning again: what
`query --stream` takes for the same update) and the time from the message's arrival (its callback)
to ~/base_poses being published; the peer also measures from its publish to the path's receipt.

    python tools/bench_ros.py [--maps maps/pr2] [--runs 7]

Writes the table to docs/bench/ros.md (atomically), which docs/ros.md includes.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import platform
import statistics
import sys
import time
from pathlib import Path

from bench_output import write_atomic

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

ARENA = ROOT / "examples/buildings/wrs_arena"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", default="maps/pr2")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--out", default=str(ROOT / "docs/bench/ros.md"))
    args = ap.parse_args()

    from std_msgs.msg import String
    from support.ros_peer import NodeProcess, Peer, ros_env

    from placement.ros.messages import grid_message
    from placement.ros.recording import now
    from placement.scene.occupancy import load_map_image

    env = ros_env()
    os.environ.update(env)
    node = NodeProcess(["--maps", str(Path(args.maps).resolve())], env)
    started = node.ready()
    peer = Peer(int(env["ROS_DOMAIN_ID"]))
    try:
        image = load_map_image(ARENA / "map.yaml")
        crate = image.values.copy()
        r0 = int((1.35 - image.origin[1]) / image.resolution)
        c0 = int((1.1 - image.origin[0]) / image.resolution)
        crate[r0 : r0 + 8, c0 : c0 + 8] = 100
        grids = [grid_message(v, image.resolution, image.origin, "map", now()) for v in (image.values, crate)]
        text = (ARENA / "tidy_up.yaml").read_text().replace("occupancy_map: map.yaml\n", "")
        texts = [text, text.replace("position: [0.85, 1.85, 0.6405]", "position: [0.95, 1.85, 0.6405]")]
        assert texts[0] != texts[1]
        peer.connected(peer.scene)
        peer.publish_and_wait(lambda: peer.map.publish(grids[0]), "/map")
        first = peer.publish_and_wait(lambda: peer.scene.publish(String(data=texts[0])), "/placement/scene")
        assert first["status"] == "applied", first

        def pose(x, y, z=0.0, yaw=0.0):
            from geometry_msgs.msg import PoseStamped

            msg = PoseStamped()
            msg.header.frame_id = "map"
            msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = x, y, z
            msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
            return msg

        changes = {
            "object moved (~/objects/mug)": (
                "/placement/objects/mug",
                lambda i: peer.object("mug").publish(pose(0.85 + 0.1 * (i % 2), 1.85, 0.6405)),
            ),
            "start moved (~/start)": (
                "/placement/start",
                lambda i: peer.start.publish(pose(0.82 + 0.1 * (i % 2), 0.69, 0.0, 1.637)),
            ),
            "map changed (/map, a crate)": ("/map", lambda i: peer.map.publish(grids[(i + 1) % 2])),
            "scene replaced (~/scene)": (
                "/placement/scene",
                lambda i: peer.scene.publish(String(data=texts[(i + 1) % 2])),
            ),
        }
        rows = []
        for label, (source, send) in changes.items():
            plan_ms, arrive_ms, wire_ms = [], [], []
            for i in range(args.runs):
                paths = len(peer.paths)
                plans = len(peer.statuses("plan"))
                t = time.perf_counter()
                line = peer.publish_and_wait(functools.partial(send, i), source)
                assert line["status"] == "applied", line
                assert peer.spin_until(functools.partial(lambda n: len(peer.paths) > n, paths))
                wire_ms.append((time.perf_counter() - t) * 1e3)
                status = peer.statuses("plan")[plans]
                plan_ms.append(status["timings_ms"]["apply"] + status["timings_ms"]["plan"])
                arrive_ms.append(status["timings_ms"]["message_to_path"])
            overhead = [a - p for a, p in zip(arrive_ms, plan_ms)]
            rows.append(
                {
                    "change": label,
                    "plan": statistics.median(plan_ms),
                    "arrive": statistics.median(arrive_ms),
                    "overhead": statistics.median(overhead),
                    "worst": max(overhead),
                    "wire": statistics.median(wire_ms),
                }
            )
            print(rows[-1], file=sys.stderr, flush=True)
    finally:
        peer.close()
        node.stop()
    head = [
        "change",
        "planning [ms]",
        "message to path [ms]",
        "beyond planning [ms]",
        "beyond planning, worst [ms]",
        "publish to receipt [ms]",
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        cells = [r["change"], *(f"{r[k]:.1f}" for k in ("plan", "arrive", "overhead", "worst", "wire"))]
        lines.append("| " + " | ".join(cells) + " |")
    text = "\n".join(lines) + "\n"
    text += (
        f"\nScene: examples/buildings/wrs_arena (8 steps, the default method, maps `{Path(args.maps).name}`); "
        f"medians of {args.runs} changes each; 'message to path': from the node's callback to ~/base_poses "
        "published, as its status line reports; 'planning': applying the change and planning again; 'beyond "
        "planning': the rest (waking the worker, the status lines, building and publishing the path); 'publish to receipt': the peer's publish to its receipt of the path, "
        f"through Fast DDS on this machine. Node ready {started:.1f} s after start. "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}.\n"
    )
    print(text)
    write_atomic(Path(args.out), text)


if __name__ == "__main__":
    main()
