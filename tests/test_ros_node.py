"""`placement ros serve` with a real ROS 2 client: the node in a subprocess, a test node here (rclpy,
Fast DDS, a random domain, localhost discovery).

What it must hold: the plan on ~/plan is `placement query --json`'s for the same scene (timings
aside); ~/base_poses are the plan's base poses; a moved object or an obstacle added to the map gives
a fresh planner's plan; every bad message gets a refusal on ~/status and changes nothing, and the
node answers the next good one; the markers hold one footprint per placement; ~/reach_goal is answered
as the live planner answers it in this process."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import OccupancyGrid
from scipy.spatial.transform import Rotation
from std_msgs.msg import String
from support.cli import run
from support.fk import world_tcp
from support.ros_peer import NodeProcess, Peer, ros_env

from placement.planning import Planner
from placement.ros.live import LivePlanner
from placement.ros.messages import grid_message, grid_of
from placement.ros.recording import now
from placement.scene import load_scene
from placement.scene.occupancy import load_map_image

pytestmark = pytest.mark.slow

ARENA = Path(__file__).resolve().parents[1] / "examples" / "buildings" / "wrs_arena"
NODE = "/placement"


def without_timings(doc):
    """The plan document without what differs between two runs of one plan: timings, the scene's name
    (a scene sent as text is named 'scene'), an update's report."""
    if isinstance(doc, dict):
        return {k: without_timings(v) for k, v in doc.items() if k not in ("timings_ms", "scene", "update")}
    if isinstance(doc, list):
        return [without_timings(v) for v in doc]
    return doc


def scene_text() -> str:
    """The arena's scene file without its `occupancy_map` (the node gets the map on /map)."""
    return (ARENA / "tidy_up.yaml").read_text().replace("occupancy_map: map.yaml\n", "")


def pose(x, y, z=0.0, yaw=0.0, frame="map") -> PoseStamped:
    msg = PoseStamped()
    msg.header.frame_id = frame
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = float(x), float(y), float(z)
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return msg


@pytest.fixture(scope="module")
def arena_grid():
    return load_map_image(ARENA / "map.yaml")


@pytest.fixture(scope="module")
def ros(maps_dir, tmp_path_factory):
    env = ros_env()
    with pytest.MonkeyPatch.context() as mp:
        for k, v in env.items():
            mp.setenv(k, v)
        record = tmp_path_factory.mktemp("rec") / "run.mcap"
        node = NodeProcess(["--maps", str(maps_dir), "--record", str(record)], env)
        started = node.ready()
        peer = Peer(int(env["ROS_DOMAIN_ID"]))
        node.record = record
        try:
            yield node, peer, started
        finally:
            peer.close()
            node.stop()


@pytest.fixture(scope="module")
def first_plan(ros, arena_grid, maps_dir):
    """The map and the scene published, and the plan they give."""
    node, peer, _ = ros
    peer.connected(peer.scene)
    grid = grid_message(arena_grid.values, arena_grid.resolution, arena_grid.origin, "map", now())
    assert peer.publish_and_wait(lambda: peer.map.publish(grid), "/map")["status"] == "applied"  # no scene yet
    plans = len(peer.statuses("plan"))
    status = peer.publish_and_wait(lambda: peer.scene.publish(String(data=scene_text())), f"{NODE}/scene")
    assert status["status"] == "applied", status
    status = peer.statuses("plan")[plans]
    return status, peer.plans[-1]


def test_the_node_starts_fast_and_plans_what_query_plans(ros, first_plan, maps_dir):
    node, peer, started = ros
    assert started < 30  # the kernels compiled by the suite's other tests or `make install`
    status, plan = first_plan
    assert status["status"] == "planned", status
    query = run("query", str(ARENA / "tidy_up.yaml"), "--maps", str(maps_dir), "--json")
    assert query.returncode == 0, query.stderr
    want = json.loads(query.stdout)
    for a, b in zip(plan["steps"], want["steps"]):
        if without_timings(a) != without_timings(b):
            print("DIFF", {k: (a[k], b.get(k)) for k in a if without_timings(a[k]) != without_timings(b.get(k))})
            break
    assert without_timings(plan) == without_timings(want)


def test_base_poses_and_markers_are_the_plans(ros, first_plan):
    node, peer, _ = ros
    _, plan = first_plan
    path = peer.paths[-1]
    assert path.header.frame_id == "map"
    got = [
        (p.pose.position.x, p.pose.position.y, 2 * math.atan2(p.pose.orientation.z, p.pose.orientation.w))
        for p in path.poses
    ]
    want = [tuple(s["base"]) for s in plan["steps"]]
    assert len(got) == len(want) == 8
    for g, w in zip(got, want):
        assert g[:2] == pytest.approx(w[:2], abs=1e-9)
        assert math.remainder(g[2] - w[2], 2 * math.pi) == pytest.approx(0.0, abs=1e-6)  # the document: 6 decimals
    markers = peer.markers[-1].markers
    assert markers[0].action == markers[0].DELETEALL  # a new plan replaces the old markers
    footprints = [m for m in markers[1:] if m.ns == "footprint"]
    assert sorted(m.id for m in footprints) == [s["step"] for s in plan["steps"]]
    for m, s in zip(sorted(footprints, key=lambda m: m.id), plan["steps"]):
        assert (m.pose.position.x, m.pose.position.y) == pytest.approx(s["base"][:2], abs=1e-9)
    labels = [m.text for m in markers if m.ns == "label"]
    assert labels[0].startswith("0 pick cracker_box / ") and labels[0].endswith(" s")


def test_a_moved_object_gives_the_fresh_planners_plan(ros, first_plan, maps_dir):
    node, peer, _ = ros
    line = peer.publish_and_wait(
        lambda: peer.object("mug").publish(pose(0.95, 1.85, 0.6405, 0.3)), f"{NODE}/objects/mug"
    )
    assert line["status"] == "applied" and line["updated"] == ["mug"], line
    scene = load_scene(ARENA / "tidy_up.yaml")
    fresh = Planner(scene, "global", maps_dir)
    fresh.update({"objects": [{"name": "mug", "position": [0.95, 1.85, 0.6405], "yaw": 0.3}]})
    again = Planner(fresh.scene, "global", maps_dir).plan().to_json()
    assert without_timings(peer.plans[-1]) == without_timings(again)


def crate_grid(image):
    """The arena's map with a crate on the floor beside the long table b: 0.4 m square of occupied cells."""
    values = image.values.copy()
    r0 = int((1.35 - image.origin[1]) / image.resolution)
    c0 = int((1.1 - image.origin[0]) / image.resolution)
    values[r0 : r0 + 8, c0 : c0 + 8] = 100
    return grid_message(values, image.resolution, image.origin, "map", now())


def test_an_obstacle_added_to_the_map_gives_the_fresh_planners_plan(ros, first_plan, arena_grid, maps_dir):
    node, peer, _ = ros
    grid = crate_grid(arena_grid)
    line = peer.publish_and_wait(lambda: peer.map.publish(grid), "/map")
    assert line["status"] == "applied", line
    live = LivePlanner(maps_dir)
    live.set_map(grid_of(grid, None))
    live.set_scene(scene_text())
    live.move_object("mug", [0.95, 1.85, 0.6405], [0, 0, math.sin(0.15), math.cos(0.15)], "test")
    fresh = live.plan().to_json()
    assert without_timings(peer.plans[-1]) == without_timings(fresh)
    assert without_timings(peer.plans[-1]) != without_timings(first_plan[1])  # the crate changed the plan


def bad_grid(width, height, data, frame="map") -> OccupancyGrid:
    msg = OccupancyGrid()
    msg.header.frame_id = frame
    msg.info.width, msg.info.height, msg.info.resolution = width, height, 0.05
    msg.info.origin.orientation.w = 1.0
    msg.data = data
    return msg


BAD = [
    ("/map", lambda p: p.map.publish(bad_grid(10, 10, [0] * 5)), "data holds 5 values for 10 x 10"),
    ("/map", lambda p: p.map.publish(bad_grid(10_000, 10_000, [])), "100,000,000 cells, more than"),
    ("/map", lambda p: p.map.publish(bad_grid(2, 2, [0, 0, 0, 0], frame="")), "no frame_id"),
    (f"{NODE}/scene", lambda p: p.scene.publish(String(data="version: [1")), "invalid YAML at line 2"),
    (f"{NODE}/scene", lambda p: p.scene.publish(String(data="version: 1\nrobot: {start: [0, 0, 0]}\n")), "task"),
    (f"{NODE}/start", lambda p: p.start.publish(pose(float("nan"), 0.0)), "not finite"),
    (f"{NODE}/start", lambda p: p.start.publish(pose(1.0, 1.0, frame="odom")), "'odom', expected the map frame 'map'"),
    (f"{NODE}/objects/nosuch", lambda p: p.object("nosuch").publish(pose(1.0, 1.0, 0.7)), "unknown object 'nosuch'"),
]


@pytest.mark.parametrize("source, send, words", BAD, ids=[w.split(",")[0][:30] for _, _, w in BAD])
def test_a_bad_message_is_refused_and_changes_nothing(ros, first_plan, source, send, words):
    node, peer, _ = ros
    before = without_timings(peer.plans[-1])
    line = peer.publish_and_wait(lambda: send(peer), source)
    assert line["status"] == "refused" and words in line["error"], line
    plans = len(peer.statuses("plan"))
    answer = peer.plan_now()
    assert answer.success, answer.message
    peer.wait_plan(plans)
    assert without_timings(peer.plans[-1]) == before
    assert node.proc.poll() is None


def test_a_reach_goal_is_answered_with_a_base_pose_whose_ik_reaches_it(ros, first_plan, pr2):
    node, peer, _ = ros
    # the cracker box's pre-grasp (its grasp pose itself is inside the box, which a reach collides with)
    goal = np.asarray(first_plan[1]["steps"][0]["tcp"][0], dtype=float)
    msg = pose(*goal[:3])
    q = msg.pose.orientation
    q.x, q.y, q.z, q.w = (float(v) for v in goal[3:7])
    answers = len(peer.reach)
    line = peer.publish_and_wait(lambda: peer.reach_goal.publish(msg), f"{NODE}/reach_goal")
    assert line["status"] == "answered", line
    assert peer.spin_until(lambda: len(peer.reach) > answers)
    base = peer.reach[-1]
    assert base.header.frame_id == "map"
    yaw = 2 * math.atan2(base.pose.orientation.z, base.pose.orientation.w)
    assert [base.pose.position.x, base.pose.position.y] == pytest.approx(line["base"][:2], abs=1e-6)
    assert math.remainder(yaw - line["base"][2], 2 * math.pi) == pytest.approx(0.0, abs=1e-6)
    # independent FK (pinocchio, joint by joint) of the answer's IK solution at the answered base
    T = world_tcp(pr2, line["arm"], line["joints"], line["base"])
    assert T[:3, 3] == pytest.approx(goal[:3], abs=2e-3)
    want = Rotation.from_quat(goal[3:7]).as_matrix()
    assert np.degrees(Rotation.from_matrix(want.T @ T[:3, :3]).magnitude()) < 1.0


def test_a_reach_goal_out_of_any_reach_says_why(ros, first_plan):
    node, peer, _ = ros
    line = peer.publish_and_wait(lambda: peer.reach_goal.publish(pose(1.4, -0.6, 3.0)), f"{NODE}/reach_goal")
    assert line["status"] == "unreachable" and line["error"], line


def test_messages_that_arrive_while_it_plans_are_coalesced(ros, first_plan, arena_grid, maps_dir):
    """Ten moves in a burst: fewer plans than moves, and the last plan is the last move's."""
    node, peer, _ = ros
    grid = crate_grid(arena_grid)
    assert peer.publish_and_wait(lambda: peer.map.publish(grid), "/map")["status"] == "applied"
    mug = peer.object("mug")
    plans = len(peer.statuses("plan"))
    moves = len(peer.statuses(f"{NODE}/objects/mug"))
    xs = [0.80 + 0.02 * i for i in range(10)]
    for x in xs:
        mug.publish(pose(x, 1.85, 0.6405))
    assert peer.spin_until(lambda: len(peer.statuses("plan")) > plans)
    answer = peer.plan_now()  # after the burst: whatever came last is applied by now
    assert answer.success, answer.message
    applied = len(peer.statuses(f"{NODE}/objects/mug")) - moves
    assert 1 <= applied < len(xs)  # newest wins
    live = LivePlanner(maps_dir)
    live.set_map(grid_of(grid, None))
    live.set_scene(scene_text())
    live.move_object("mug", [xs[-1], 1.85, 0.6405], [0, 0, 0, 1], "test")
    want = without_timings(live.plan().to_json())
    assert peer.spin_until(
        lambda: len(peer.plans) == sum(s["status"] in ("planned", "infeasible") for s in peer.statuses("plan"))
    )
    assert without_timings(peer.plans[-1]) == want


def test_amcl_and_the_start_topic_move_the_start(ros, first_plan, arena_grid, maps_dir):
    """After the coalescing test: the crate map, the mug at x = 0.98."""
    node, peer, _ = ros
    amcl = PoseWithCovarianceStamped()
    amcl.header.frame_id = "map"
    amcl.pose.pose = pose(0.9, 0.6, 0.0, 1.2).pose
    peer.connected(peer.amcl)
    line = peer.publish_and_wait(lambda: peer.amcl.publish(amcl), "/amcl_pose")
    assert line["status"] == "applied" and line["updated"] == ["start"], line
    live = LivePlanner(maps_dir)
    live.set_map(grid_of(crate_grid(arena_grid), None))
    live.set_scene(scene_text())
    live.move_object("mug", [0.98, 1.85, 0.6405], [0, 0, 0, 1], "test")
    live.move_start(0.9, 0.6, 1.2, "test")
    assert without_timings(peer.plans[-1]) == without_timings(live.plan().to_json())
    line = peer.publish_and_wait(lambda: peer.start.publish(pose(0.82, 0.69, 0.0, 1.637)), f"{NODE}/start")
    assert line["status"] == "applied", line
    live.move_start(0.82, 0.69, 1.637, "test")
    assert without_timings(peer.plans[-1]) == without_timings(live.plan().to_json())


def test_a_node_started_with_a_scene_in_a_namespace_plans_at_once(ros, maps_dir):
    node, peer, _ = ros
    # a domain of its own: in the first node's domain the test peer's latched crate map on the global
    # /map would reach this node too, which would then plan (also) on that map
    env = ros_env()
    while env["ROS_DOMAIN_ID"] == os.environ["ROS_DOMAIN_ID"]:
        env = ros_env()
    other = NodeProcess([str(ARENA / "tidy_up.yaml"), "--maps", str(maps_dir), "--namespace", "r1"], env)
    try:
        other.ready()
        listener = Peer(int(env["ROS_DOMAIN_ID"]), base="/r1/placement")
        try:
            assert listener.spin_until(lambda: listener.plans and listener.paths)  # latched: late joiners get it
        finally:
            listener.close()
    finally:
        assert other.stop() == 0
    query = run("query", str(ARENA / "tidy_up.yaml"), "--maps", str(maps_dir), "--json")
    assert without_timings(listener.plans[-1]) == without_timings(json.loads(query.stdout))
    assert len(listener.paths[-1].poses) == 8


def test_stopped_it_leaves_a_recording_of_every_map_scene_and_plan(ros):
    """Last in the module: SIGTERM stops the node cleanly, and its MCAP file holds what it published."""
    node, peer, _ = ros
    plans = [s for s in peer.statuses("plan") if s["status"] in ("planned", "infeasible")]
    code = node.stop()
    assert code == 0, "\n".join(node.lines[-20:])
    assert not any("Traceback" in ln for ln in node.lines), node.lines
    with open(node.record, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        got: dict[str, list] = {}
        for schema, channel, _, msg in reader.iter_decoded_messages():
            got.setdefault(channel.topic, []).append((schema.name, msg))
    assert {t: {n for n, _ in v} for t, v in got.items()} == {
        "/map": {"nav_msgs/msg/OccupancyGrid"},
        f"{NODE}/scene": {"std_msgs/msg/String"},
        f"{NODE}/plan": {"std_msgs/msg/String"},
        f"{NODE}/base_poses": {"nav_msgs/msg/Path"},
        f"{NODE}/markers": {"visualization_msgs/msg/MarkerArray"},
    }
    assert len(got[f"{NODE}/plan"]) == len(plans)
    assert [json.loads(m.data) for _, m in got[f"{NODE}/plan"]][-1] == peer.plans[-1]
    assert len(got["/map"]) == 3  # the arena's, then with the crate (twice)
