"""The 3D viewer without a browser: what it puts in the scene, step switching, layers, the map cloud.

The browser test (tests/test_viewer_browser.py) checks that it is drawn; these check what is sent.
"""

from __future__ import annotations

import json
import math
import statistics
import urllib.request
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("viser", reason="the viewer extra is not installed: pip install 'placement[view]'")

import pinocchio as pin

from placement.viewer import ViewerError, view_map, view_scene
from placement.viewer.colors import Scale, layer_image
from placement.viewer.geometry import ear_clip, pose_matrix, prism
from placement.viewer.map_view import approach_bins, best_values, cloud
from placement.viewer.server import HOST, check_port

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"


@pytest.fixture(scope="module")
def scene_view(maps_dir):
    v = view_scene(EXAMPLE, maps=maps_dir, method="sequential", port=0)  # all four cost layers
    yield v
    v.stop()


def base_pose_drawn(view) -> np.ndarray:
    """(4, 4) world pose of the robot's base frame as drawn: the root node's pose times the model's
    base frame placement at the configuration shown."""
    d = view.content.robot_drawing
    R = pin.Quaternion(*d.frame.wxyz).toRotationMatrix()  # (w, x, y, z) constructor order
    root = np.eye(4)
    root[:3, :3], root[:3, 3] = R, d.frame.position
    return root @ d.data.oMf[d.robot.base_frame_id].homogeneous


def test_served_on_loopback_only_and_the_page_loads(scene_view):
    assert scene_view.url.startswith(f"http://{HOST}:") and HOST == "127.0.0.1"
    assert scene_view.server.get_host() == "127.0.0.1"
    with urllib.request.urlopen(scene_view.url, timeout=10) as r:
        assert r.status == 200 and b"<html" in r.read(4000).lower()


def test_each_step_puts_the_robot_base_at_its_placement(scene_view):
    pv = scene_view.content
    assert len(pv.steps) == 6 and all(s.ok for s in pv.steps)
    for i in (2, 0, 5):
        pv.show(i)
        x, y, yaw = pv.steps[i].base
        np.testing.assert_allclose(base_pose_drawn(scene_view), pose_matrix(x, y, yaw), atol=1e-6)
        assert int(pv.slider.value) == i and f"step {pv.steps[i].step}:" in pv.info.content


def test_the_drawn_tcp_is_where_the_plan_says(scene_view):
    """Forward kinematics of the configuration shown, from the drawn base, reaches the step's last TCP
    pose (with the step's torso: the robot held at the step's fixed-joint values)."""
    pv = scene_view.content
    pv.show(1)
    s, robot = pv.steps[1], pv.robot
    T = base_pose_drawn(scene_view) @ robot.with_fixed({j: s.joints[j] for j in robot.fixed_joints}).tcp_pose(
        s.arm, s.q
    )
    assert np.linalg.norm(T[:3, 3] - s.tcp[-1][:3, 3]) < 0.01


def test_step_switch_is_fast(scene_view):
    pv = scene_view.content
    times = []
    for i in [1, 2, 3, 4, 5, 0] * 2:
        pv.show(i)
        times.append(pv.step_ms)
    assert statistics.median(times) < 100, times


def test_layers_switch_on_and_off_with_their_scales(scene_view):
    pv = scene_view.content
    for key, box in pv.toggles.items():
        box.value = key in ("navigation", "manipulation")
    pv.show(0)
    assert pv.images["navigation"].visible and pv.images["manipulation"].visible
    assert "navigation cost</b> [m]" in pv.scales.content and "[dimensionless]" in pv.scales.content
    assert "combined" not in pv.images or not pv.images["combined"].visible
    pv.toggles["navigation"].value = False
    pv.show(0)
    assert not pv.images["navigation"].visible and "navigation cost" not in pv.scales.content


def test_a_flat_layer_is_not_drawn(scene_view):
    """The last step has no next step: its heuristic is one value everywhere and tells nothing."""
    pv = scene_view.content
    last = len(pv.steps) - 1
    heur = np.asarray(pv.steps[last].maps.heuristic, dtype=float)
    assert np.nanmax(heur[np.isfinite(heur)]) == np.nanmin(heur[np.isfinite(heur)])
    assert pv.layer(last, "heuristic") is None and pv.layer(0, "heuristic") is not None


def test_layer_image_rows_and_transparency():
    layer = np.array([[0.0, 1.0, np.nan], [2.0, np.inf, 4.0]])
    img = layer_image(layer, Scale("x", "m", 0.0, 4.0))
    assert img.shape == (2, 3, 4)
    assert img[0, 2, 3] == 0 and img[1, 1, 3] == 0 and img[0, 0, 3] > 0  # not finite: transparent
    # row 0 stays the lowest y (viser draws an image's first row at its lowest y)
    np.testing.assert_array_equal(img[1, 2, :3], Scale("x", "m", 0.0, 4.0).rgb(np.array(4.0)))
    assert Scale("x", "m", 1.0, 1.0).normalise(np.array([0.0, 5.0])).tolist() == [0.5, 0.5]


def test_plan_file_is_shown_without_maps(scene_view, tmp_path):
    doc = scene_view.planner.plan().to_json()
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(doc))
    v = view_scene(EXAMPLE, plan=path, port=0)
    try:
        pv = v.content
        assert [s.base for s in pv.steps] == [tuple(s["base"]) for s in doc["steps"]]
        pv.show(3)
        np.testing.assert_allclose(base_pose_drawn(v), pose_matrix(*doc["steps"][3]["base"]), atol=1e-6)
        assert "no cost maps" in pv.scales.content and not pv.images
    finally:
        v.stop()


def test_bad_port_is_refused_before_anything_starts():
    for bad in (-1, 65536, 1.5, True):
        with pytest.raises(ViewerError, match="--port"):
            check_port(bad)


def test_polygon_prism_is_closed_and_covers_a_concave_polygon():
    pts = np.array([[0, 0], [2, 0], [2, 2], [1, 1], [0, 2]], dtype=float)  # concave at (1, 1)
    tris = ear_clip(pts)

    def area2(a, b, c):
        (ux, uy), (vx, vy) = pts[b] - pts[a], pts[c] - pts[a]
        return abs(ux * vy - uy * vx)

    area = sum(area2(*t) for t in tris) / 2
    assert len(tris) == 3 and math.isclose(area, 3.0)
    v, f = prism(pts, 0.0, 1.0)
    edges = {}
    for tri in f:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edges[(min(a, b), max(a, b))] = edges.get((min(a, b), max(a, b)), 0) + 1
    assert set(edges.values()) == {2}  # every edge shared by two faces: watertight


def test_every_kind_of_obstacle_and_the_occupancy_map_are_drawn(tmp_path):
    from support.occupancy import write_map
    from support.scenes import FULL_SCENE

    from placement.scene import load_scene
    from placement.viewer.scene_view import draw_scene
    from placement.viewer.server import start_server

    write_map(tmp_path)
    (tmp_path / "scene.yaml").write_text(FULL_SCENE)
    scene = load_scene(tmp_path / "scene.yaml")
    server = start_server(0)
    try:
        nodes = draw_scene(server, scene, 0.47)
    finally:
        server.stop()
    assert set(nodes) == {
        "/scene/tables/table_1",
        "/scene/obstacles/pillar",
        "/scene/obstacles/wall",
        "/scene/occupancy",
        "/scene/objects/cup_1",
        "/scene/objects/cup_2",
    }
    pillar = nodes["/scene/obstacles/pillar"]
    v = np.asarray(pillar.vertices)
    r = np.hypot(v[:, 0] + 1.0, v[:, 1] - 3.0)
    assert np.allclose(r, 0.2) and v[:, 2].min() == 0.0 and v[:, 2].max() == 2.0  # upright, its size
    occ = scene.occupancy
    img = np.asarray(nodes["/scene/occupancy"].image)
    assert img.shape[:2] == occ.occupied.shape
    np.testing.assert_array_equal(img[..., 3] > 0, occ.occupied)  # occupied dark, free transparent


def test_direction_bins_point_the_tcp_that_way(maps_dir):
    from placement import open_map

    grid = open_map(maps_dir, "right").grid
    from placement.maps.grid import pose_from_zyx

    down = approach_bins(grid, (0, 0, -1))
    assert 0 < down.sum() < down.size and approach_bins(grid, None).all()
    dyaw, dpitch, droll = grid.angle_steps
    for iy, ip, ir in zip(*np.nonzero(down)):
        z = pose_from_zyx(np.zeros((1, 3)), iy * dyaw, -math.pi / 2 + (ip + 0.5) * dpitch, ir * droll)[0, :3, 2]
        assert z[2] < -math.cos(math.radians(31))


def test_map_cloud_is_the_best_value_per_cell_and_is_subsampled(maps_dir):
    from placement import open_map

    m = open_map(maps_dir, "right")
    best = best_values(m.values, approach_bins(m.grid, None))
    np.testing.assert_array_equal(best, m.values.max(axis=(3, 4, 5)))
    pts, vals, reached = cloud(m.grid, best, max_points=10**9)
    assert reached == int((best > 0).sum()) == len(pts) and np.all(vals > 0)
    i = np.unravel_index(int(np.argmax(best)), best.shape)
    top = np.asarray(m.grid.origin) + (np.array(i) + 0.5) * m.grid.resolution
    np.testing.assert_allclose(pts[np.argmax(vals)], top, atol=1e-6)
    few, fvals, reached2 = cloud(m.grid, best, max_points=100)
    assert len(few) == 100 and reached2 == reached and set(fvals) <= set(vals)


def test_streamed_best_values_equal_the_whole_array_reduced(maps_dir):
    """Chunk by chunk in threads, every direction at once: the same maxima as reducing the 6D array."""
    from placement import open_map
    from placement.viewer.map_view import DIRECTIONS, best_per_direction

    streamed = best_per_direction(open_map(maps_dir, "right"), DIRECTIONS, workers=3)
    m = open_map(maps_dir, "right")
    for name, d in DIRECTIONS.items():
        want = best_values(m.values, approach_bins(m.grid, d))
        assert want.any(), name
        np.testing.assert_array_equal(streamed[name], want)


def test_map_view_threshold_and_direction(maps_dir):
    v = view_map(maps_dir, arm="left", port=0)
    try:
        mv = v.content
        assert mv.rmap.arm == "left" and mv.shown == mv.reached > 0
        mv.threshold.value = float(np.median(mv.all_values))
        mv.draw()
        assert 0 < mv.shown < mv.reached
        mv.threshold.value = 0.0
        mv.section.value = float(np.median(mv.all_points[:, 1]))
        mv.draw()
        assert 0 < mv.shown < mv.reached
        mv.section.value = mv.section.min
        mv.select("down")
        assert 0 < mv.reached and "(down)" in mv.scale.label
        assert v.timings["render_s"] < 30
    finally:
        v.stop()
    with pytest.raises(ViewerError, match="--direction"):
        view_map(maps_dir, direction="sideways")


def test_boxes_mesh_is_closed_outward_and_holds_the_boxes():
    from placement.viewer.geometry import boxes_mesh

    boxes = np.array([[0.0, 0.0, 0.1, 0.05, 0.05, 0.3], [1.0, -1.0, 0.0, 1.1, -0.9, 2.0]])
    v, f = boxes_mesh(boxes)
    assert v.shape == (16, 3) and f.shape == (24, 3)
    tri = v[f].astype(float)
    # the divergence theorem: the signed volume of a closed outward mesh is its volume
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert volume == pytest.approx(0.05 * 0.05 * 0.2 + 0.1 * 0.1 * 2.0, rel=1e-5)
    edges: dict[tuple[int, int], int] = {}
    for a, b, c in f:
        for e in ((a, b), (b, c), (c, a)):
            edges[e] = edges.get(e, 0) + 1
    assert all(edges.get((b, a)) == 1 for (a, b) in edges)  # each edge once each way: closed, oriented
    assert np.allclose(v[:8].min(axis=0), boxes[0, :3]) and np.allclose(v[:8].max(axis=0), boxes[0, 3:])


def test_the_obstacle_cloud_is_drawn_as_its_voxel_boxes(tmp_path):
    from support.pcd import pcd
    from support.scenes import base_doc

    from placement.scene import parse_scene
    from placement.viewer.scene_view import draw_scene
    from placement.viewer.server import start_server

    ys, zs = np.meshgrid(np.arange(-1.0, 1.0, 0.02), np.arange(0.0, 2.0, 0.02))
    wall = np.stack([np.full(ys.size, 0.6), ys.ravel(), zs.ravel()], axis=1)
    (tmp_path / "room.pcd").write_bytes(pcd(wall, "binary"))
    doc = base_doc()
    doc["obstacle_cloud"] = {"file": "room.pcd", "voxel": 0.05}
    scene = parse_scene(doc, tmp_path)
    server = start_server(0)
    try:
        nodes = draw_scene(server, scene, 0.47)
    finally:
        server.stop()
    mesh = nodes["/scene/obstacle_cloud"]
    v = np.asarray(mesh.vertices)
    assert len(v) == 8 * len(scene.cloud.boxes)
    assert np.allclose(v.min(axis=0), scene.cloud.boxes[:, :3].min(axis=0))
    assert np.allclose(v.max(axis=0), scene.cloud.boxes[:, 3:].max(axis=0))
