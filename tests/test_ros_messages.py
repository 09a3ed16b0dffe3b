"""ROS 2 messages in and out (placement.ros.messages, placement.ros.live, placement.ros.recording), on
real rclpy message objects: literal grids, a plain-numpy reference on random grids and random junk
(hypothesis), poses refused for their frame and numbers, schemas that decode what rclpy encoded."""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import OccupancyGrid
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import String
from support.cli import ROOT, assert_one_line_error, run

from placement.errors import PlacementError
from placement.ros.live import scene_from_text, upright_yaw
from placement.ros.messages import RosInputError, base_of, grid_message, occupancy_of, stamped_pose
from placement.ros.recording import Recorder, now, schema_text
from placement.scene import SceneError, load_scene


def grid(values, resolution=0.05, origin=(-1.0, 2.0), frame="map") -> OccupancyGrid:
    return grid_message(np.asarray(values, dtype=np.int8), resolution, origin, frame, now())


def test_a_literal_grid_reads_as_map_server_means_it():
    # rows bottom (y lowest) first, as the grid's data: -1 unknown, 0..64 free, 65..100 occupied
    values = [
        [0, 64, 65],  # y in [2.00, 2.05)
        [100, -1, 10],  # y in [2.05, 2.10)
    ]
    occ = occupancy_of(grid(values), "map")
    assert occ.occupied.tolist() == [[False, False, True], [True, True, False]]
    assert occ.resolution == 0.05 and occ.origin == (-1.0, 2.0, 0.0)
    assert occ.extent == pytest.approx((-1.0, 2.0, -0.85, 2.1))
    free = occupancy_of(grid(values), "map", unknown="free")
    assert free.occupied.tolist() == [[False, False, True], [True, False, False]]
    strict = occupancy_of(grid(values), "map", occupied_percent=100)
    assert strict.occupied.tolist() == [[False, False, False], [True, True, False]]
    costly = occupancy_of(grid(values), "map", unknown="cost", unknown_cost=5.0)
    assert costly.occupied.tolist() == free.occupied.tolist()
    assert costly.unknown_cells.tolist() == [[False, False, False], [False, True, False]] and costly.unknown_cost == 5.0


def test_the_float32_resolution_is_what_the_map_author_wrote():
    msg = deserialize_message(serialize_message(grid([[0]], resolution=0.05)), OccupancyGrid)  # over the wire
    assert msg.info.resolution != 0.05  # a float32 field
    assert occupancy_of(msg, "map").resolution == 0.05


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12), st.data(), st.sampled_from(["occupied", "free"]), st.integers(1, 100))
def test_random_grids_match_the_plain_reference(h, w, data, unknown, percent):
    values = np.array(data.draw(st.lists(st.integers(-1, 100), min_size=h * w, max_size=h * w)), dtype=np.int8)
    values = values.reshape(h, w)
    occ = occupancy_of(grid(values), "map", unknown, percent)
    want = [[(v >= percent) or (v < 0 and unknown == "occupied") for v in row] for row in values.tolist()]
    assert occ.occupied.tolist() == want


@settings(max_examples=150, deadline=None)
@given(
    st.integers(0, 70_000),
    st.integers(0, 70_000),
    st.lists(st.integers(-128, 127), max_size=40),
    st.floats(allow_nan=True, allow_infinity=True, width=32),
    st.tuples(st.floats(allow_nan=True), st.floats(allow_nan=True)),
    st.sampled_from(["map", "", "/map", "odom"]),
    st.tuples(*[st.floats(-2, 2)] * 4),
)
def test_any_grid_is_read_or_refused_in_one_line(w, h, data, res, origin, frame, q):
    msg = OccupancyGrid()
    msg.header.frame_id = frame
    msg.info.width, msg.info.height, msg.info.resolution = w, h, res
    msg.info.origin.position.x, msg.info.origin.position.y = origin
    o = msg.info.origin.orientation
    o.x, o.y, o.z, o.w = q
    msg.data = data
    try:
        occ = occupancy_of(msg, "map")
    except RosInputError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("/map: ")
        return
    assert occ.occupied.shape == (h, w) and occ.occupied.size == len(data)
    assert math.isfinite(occ.resolution) and occ.resolution > 0


@pytest.mark.parametrize(
    "change, words",
    [
        (dict(width=3, height=3, data=[0] * 8), "data holds 8 values for 3 x 3 = 9 cells"),
        (dict(width=10_000, height=5_000, data=[]), "50,000,000 cells, more than the 40,000,000"),
        (dict(width=0, height=3, data=[]), "the grid is empty"),
        (dict(resolution=0.0), "resolution 0 m"),
        (dict(frame="odom"), "pose in 'odom', expected the map frame 'map'"),
        (dict(tilt=0.5), "the origin is tilted"),
        (dict(data=[0, 101, 0, 0]), "values must be -1 (unknown) or 0..100, got 0..101"),
        (dict(x=float("nan")), "not finite"),
        (dict(x=2e6), "beyond +-1e+06 m"),
    ],
)
def test_a_bad_grid_is_refused_naming_the_problem(change, words):
    msg = OccupancyGrid()
    msg.header.frame_id = change.get("frame", "map")
    msg.info.width, msg.info.height = change.get("width", 2), change.get("height", 2)
    msg.info.resolution = change.get("resolution", 0.1)
    msg.info.origin.position.x = change.get("x", 0.0)
    tilt = change.get("tilt", 0.0)
    msg.info.origin.orientation.x, msg.info.origin.orientation.w = math.sin(tilt / 2), math.cos(tilt / 2)
    msg.data = change.get("data", [0, 0, 0, 0])
    with pytest.raises(RosInputError, match=".*") as err:
        occupancy_of(msg, "map")
    assert words in str(err.value)


def stamped(x=1.0, y=2.0, z=0.5, q=(0.0, 0.0, 0.0, 1.0), frame="map", covariance=False):
    msg = PoseWithCovarianceStamped() if covariance else PoseStamped()
    msg.header.frame_id = frame
    pose = msg.pose.pose if covariance else msg.pose
    pose.position.x, pose.position.y, pose.position.z = x, y, z
    o = pose.orientation
    o.x, o.y, o.z, o.w = q
    return msg


def test_poses_in_the_map_frame_are_read_in_ros_units():
    q = (0.0, 0.0, math.sin(0.4), math.cos(0.4))
    position, quat = stamped_pose(stamped(q=q), "map", "t")
    assert position.tolist() == [1.0, 2.0, 0.5] and quat.tolist() == pytest.approx(q)
    assert base_of(stamped(q=q, frame="/map", covariance=True), "map", "t") == pytest.approx((1.0, 2.0, 0.8))


@pytest.mark.parametrize(
    "msg, words",
    [
        (stamped(frame="odom"), "t: pose in 'odom', expected the map frame 'map'"),
        (stamped(frame=""), "t: pose in no frame_id, expected"),
        (stamped(x=float("nan")), "t: position: not finite"),
        (stamped(y=float("inf")), "t: position: not finite"),
        (stamped(q=(0.0, 0.0, 0.0, 0.0)), "not a unit quaternion"),
        (stamped(q=(0.0, 0.0, float("nan"), 1.0)), "orientation not finite"),
        (stamped(x=1e308), "beyond"),
    ],
)
def test_a_bad_pose_is_refused_naming_the_problem(msg, words):
    with pytest.raises(RosInputError) as err:
        stamped_pose(msg, "map", "t")
    assert words in str(err.value)


def test_an_upright_orientation_gives_its_yaw_and_a_tilted_one_is_refused():
    assert upright_yaw([0.0, 0.0, math.sin(1.0), math.cos(1.0)], "t") == pytest.approx(2.0)
    with pytest.raises(PlacementError, match="tilts 90 deg from upright"):
        upright_yaw([math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)], "t")


def test_a_scene_text_is_checked_like_a_file(tmp_path):
    with pytest.raises(SceneError, match="~/scene: invalid YAML"):
        scene_from_text("version: [", tmp_path)
    with pytest.raises(SceneError, match="~/scene: the scene is empty"):
        scene_from_text("  \n", tmp_path)
    with pytest.raises(SceneError, match="more than the"):
        scene_from_text("#" * (17 * 2**20), tmp_path)


@pytest.mark.parametrize(
    "msg",
    [String(data="hello"), grid([[0, 100], [-1, 5]]), stamped(q=(0.0, 0.0, math.sin(0.2), math.cos(0.2)))],
    ids=lambda m: type(m).__name__,
)
def test_recorded_messages_decode_as_what_was_written(msg):
    """The schema text lets an independent decoder (mcap_ros2) read what rclpy serialised."""
    buf = io.BytesIO()
    rec = Recorder(buf)
    rec.write("/t", msg, log_time_ns=123)
    rec.close()
    buf.seek(0)
    ((schema, channel, raw, decoded),) = make_reader(buf, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
    assert channel.topic == "/t" and raw.log_time == 123
    assert schema.name == f"{type(msg).__module__.split('.')[0]}/msg/{type(msg).__name__}"
    if isinstance(msg, OccupancyGrid):
        assert list(decoded.data) == list(msg.data) and decoded.info.width == 2
        assert decoded.info.resolution == pytest.approx(msg.info.resolution)
    elif isinstance(msg, String):
        assert decoded.data == "hello"
    else:
        assert decoded.pose.orientation.z == msg.pose.orientation.z and decoded.header.frame_id == "map"


def test_a_schema_holds_each_type_it_uses_once():
    text = schema_text("visualization_msgs/msg/MarkerArray")
    heads = [ln for ln in text.splitlines() if ln.startswith("MSG: ")]
    assert len(heads) == len(set(heads))
    for needed in ("visualization_msgs/Marker", "std_msgs/Header", "geometry_msgs/Pose", "builtin_interfaces/Time"):
        assert f"MSG: {needed}" in heads


@pytest.mark.slow
def test_without_the_ros_extra_the_commands_say_how_to_install_it(tmp_path):
    """rclpy hidden (a package of that name that cannot be imported first on the path)."""
    fake = tmp_path / "rclpy"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('hidden for the test', name='rclpy')\n")
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    for args in (["ros", "serve"], ["query", str(ROOT / "examples" / "table_clearing.yaml"), "--mcap", "x.mcap"]):
        proc = subprocess.run(
            [sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, env=env, cwd=tmp_path
        )
        assert proc.returncode == 2, proc.stderr
        assert proc.stderr.strip().splitlines()[-1].endswith("pip install 'placement[ros]'"), proc.stderr
        assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_query_records_the_scene_and_the_plan_as_ros_messages(tmp_path, maps_dir):
    scene = ROOT / "examples" / "buildings" / "wrs_arena" / "tidy_up.yaml"
    out = tmp_path / "plan.mcap"
    proc = run("query", str(scene), "--maps", str(maps_dir), "--json", "--mcap", str(out))
    assert proc.returncode == 0, proc.stderr
    with open(out, "rb") as fh:
        got = {
            c.topic: (s.name, m)
            for s, c, _, m in make_reader(fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
        }
    assert {t: n for t, (n, _) in got.items()} == {
        "/placement/scene": "std_msgs/msg/String",
        "/map": "nav_msgs/msg/OccupancyGrid",
        "/placement/plan": "std_msgs/msg/String",
        "/placement/base_poses": "nav_msgs/msg/Path",
        "/placement/markers": "visualization_msgs/msg/MarkerArray",
    }
    assert got["/placement/scene"][1].data == scene.read_text()
    assert json.loads(got["/placement/plan"][1].data) == json.loads(proc.stdout)
    plan = json.loads(proc.stdout)
    poses = got["/placement/base_poses"][1].poses
    got_xy = np.array([(p.pose.position.x, p.pose.position.y) for p in poses])
    assert got_xy == pytest.approx(np.array([s["base"][:2] for s in plan["steps"]]), abs=1e-9)
    grid = got["/map"][1]
    occ = load_scene(scene).occupancy
    assert (grid.info.width, grid.info.height) == occ.occupied.shape[::-1]
    assert (np.asarray(grid.data).reshape(occ.occupied.shape) == 100).tolist() == occ.occupied.tolist()
    assert not list(tmp_path.glob(".*tmp"))  # written whole, nothing left beside it


@pytest.mark.slow
def test_a_query_that_cannot_write_its_recording_stops_before_planning(tmp_path):
    proc = run("query", str(ROOT / "examples" / "table_clearing.yaml"), "--mcap", str(tmp_path / "no" / "x.mcap"))
    assert_one_line_error(proc, "--mcap", "does not exist")


def test_a_reach_question_leaves_the_live_plan_as_it_was(maps_dir):
    """The reach answer plans one pose over the live planner's robot and maps (a copy of it): the live
    planner's scene and plan stay, and a pose out of every reach is answered with why."""
    from support.plans import strip_timings

    from placement.ros.live import LivePlanner

    arena = ROOT / "examples" / "buildings" / "wrs_arena"
    live = LivePlanner(maps_dir, origin_dir=arena)
    assert live.set_scene((arena / "tidy_up.yaml").read_text()).applied
    before = strip_timings(live.plan().to_json())
    goal = live.plan().steps[0].tcp[0]  # the first pick's pre-grasp
    from scipy.spatial.transform import Rotation

    step = live.reach(goal[:3, 3], Rotation.from_matrix(goal[:3, :3]).as_quat())
    assert step.ok and step.action == "reach"
    far = live.reach([500.0, 500.0, 1.0], [0.0, 1.0, 0.0, 0.0])
    assert not far.ok and "no base placement reaches the target" in far.reason
    assert strip_timings(live.plan().to_json()) == before
    assert live.planner.scene.task == load_scene(arena / "tidy_up.yaml").task


def test_a_grid_turned_about_z_is_read_as_nav2_reads_it(caplog):
    """map_server publishes a map YAML's origin yaw; Nav2's costmap and AMCL place the grid unrotated:
    the same cells as at yaw 0, and a warning with the yaw."""
    grids = []
    for yaw in (0.0, 0.5):
        msg = OccupancyGrid()
        msg.header.frame_id = "map"
        msg.info.width, msg.info.height, msg.info.resolution = 3, 2, 0.1
        msg.info.origin.position.x, msg.info.origin.position.y = 1.0, -2.0
        msg.info.origin.orientation.z, msg.info.origin.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        msg.data = [0, 100, -1, 0, 0, 100]
        with caplog.at_level("WARNING"):
            grids.append(occupancy_of(msg, "map"))
    assert grids[1].origin == grids[0].origin and np.array_equal(grids[1].occupied, grids[0].occupied)
    assert "origin yaw 0.5 rad ignored" in caplog.text
