"""Point clouds (PCD) as boxes of the arm's collision model: the parser against what wrote the file,
the voxel runs against a per-voxel reference, and a cloud in a scene."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from support.pcd import pcd
from support.scenes import base_doc

from placement.collision import SceneCollision
from placement.scene import SceneError, parse_scene
from placement.scene.cloud import FLOOR_IGNORE, CloudError, load_cloud, parse_pcd, voxel_boxes

coords = st.floats(-50, 50, allow_nan=False, width=32)
clouds = st.lists(st.tuples(coords, coords, coords), min_size=0, max_size=40).map(
    lambda v: np.array(v, dtype=np.float64).reshape(-1, 3)
)


@given(clouds, st.sampled_from(["ascii", "binary"]), st.booleans(), st.sampled_from([4, 8]))
def test_parsed_points_are_the_written_ones(points, kind, extra, size):
    got = parse_pcd(pcd(points, kind, extra, size))
    want = points.astype(np.float32).astype(np.float64) if size == 4 else points
    np.testing.assert_array_equal(got, want)


@given(st.binary(max_size=400))
def test_any_bytes_parse_or_fail_in_one_line(data):
    try:
        out = parse_pcd(b"VERSION 0.7\nFIELDS x y z\n" + data)
    except CloudError as exc:
        assert "\n" not in str(exc)
    else:
        assert out.ndim == 2 and out.shape[1] == 3 and np.all(np.isfinite(out))


@pytest.mark.parametrize(
    "text, words",
    [
        ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 1\nDATA binary_compressed\n", "binary_compressed"),
        ("VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nPOINTS 1\nDATA ascii\n1 2\n", "must hold 'z'"),
        (
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F I\nPOINTS 1\nDATA ascii\n1 2 3\n",
            "field 'z' must be a float",
        ),
        (
            "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 3\nDATA ascii\n1 2 3\n",
            "1 points, the header says 3",
        ),
        ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 2\nDATA binary\n" + "x" * 10, "truncated"),
        ("ply\nformat ascii 1.0\n", "not a PCD file"),
        ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 99999999999\nDATA ascii\n", "more than"),
        ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 3000000\nDATA ascii\n", "save the cloud as binary"),
    ],
)
def test_bad_files_are_one_line(text, words):
    with pytest.raises(CloudError, match=words) as err:
        parse_pcd(text.encode(), "room.pcd")
    assert str(err.value).startswith("room.pcd: ") and "\n" not in str(err.value)


def test_nan_points_are_skipped():
    pts = np.array([[1.0, 2.0, 3.0], [np.nan, 0.0, 0.0], [4.0, 5.0, 6.0]])
    np.testing.assert_array_equal(parse_pcd(pcd(pts, "binary")), pts[[0, 2]].astype(np.float32))


@given(clouds.filter(lambda p: len(p) > 0), st.sampled_from([0.05, 0.1, 0.3]))
def test_boxes_cover_exactly_the_occupied_voxels_above_the_floor(points, voxel):
    boxes = voxel_boxes(points, voxel)
    # reference: the set of voxels with a point, the floor's left out
    keys = {tuple(k) for k in np.floor(points / voxel).astype(np.int64) if (k[2] + 1) * voxel > FLOOR_IGNORE}
    covered = set()
    for x0, y0, z0, x1, y1, z1 in boxes:
        i, j = round(x0 / voxel), round(y0 / voxel)
        assert round(x1 / voxel) == i + 1 and round(y1 / voxel) == j + 1  # one column each
        covered |= {(i, j, k) for k in range(round(z0 / voxel), round(z1 / voxel))}
    assert covered == keys
    # runs are maximal: no two boxes of a column touch
    ends = {(round(b[0] / voxel), round(b[1] / voxel), round(b[5] / voxel)) for b in boxes}
    starts = {(round(b[0] / voxel), round(b[1] / voxel), round(b[2] / voxel)) for b in boxes}
    assert not ends & starts


def test_a_wall_seen_only_in_the_cloud_stops_the_arm(tmp_path, pr2):
    """A 2 m high plane of points 0.6 m in front of the PR2 (no obstacle in the scene): the right arm
    stretched forward hits a cloud box; the cup's own points (on the table) are left out."""
    ys, zs = np.meshgrid(np.arange(-1.0, 1.0, 0.02), np.arange(0.0, 2.0, 0.02))
    wall = np.stack([np.full(ys.size, 0.6), ys.ravel(), zs.ravel()], axis=1)
    doc = base_doc()
    cup = doc["objects"][0]
    cup_pts = np.array(cup["position"]) + np.random.default_rng(0).uniform(-0.02, 0.02, (50, 3))
    (tmp_path / "room.pcd").write_bytes(pcd(np.concatenate([wall, cup_pts]), "binary"))
    doc["obstacle_cloud"] = {"file": "room.pcd", "voxel": 0.05}
    scene = parse_scene(doc, tmp_path)
    assert scene.cloud is not None and len(scene.cloud.boxes) == 40  # one column per 5 cm of the wall
    lo = np.array(cup["position"]) - 0.1
    hi = np.array(cup["position"]) + 0.1
    inside = np.all((scene.cloud.boxes[:, :3] < hi) & (scene.cloud.boxes[:, 3:] > lo), axis=1)
    assert not inside.any()
    arm = pr2.arm("right")
    q = arm.home.copy()
    q[1], q[3] = 0.0, 0.0  # shoulder level, elbow straight: the hand about 0.8 m forward
    checker = SceneCollision(pr2, dataclasses.replace(scene, obstacles=(), objects=()))
    res = checker.check("right", [q], (0.0, 0.0, 0.0))
    assert not res.free and res.culprit.split(" vs ")[1].startswith("cloud[")
    far = checker.check("right", [q], (-1.0, 0.0, 0.0))
    assert far.free


def test_cloud_keys_round_trip_and_bad_ones_are_one_line(tmp_path):
    (tmp_path / "room.pcd").write_bytes(pcd(np.array([[1.0, 1.0, 1.0]]), "ascii"))
    doc = base_doc()
    doc["obstacle_cloud"] = "room.pcd"
    scene = parse_scene(doc, tmp_path)
    assert scene.cloud.voxel == 0.05 and scene.obstacle_cloud == tmp_path / "room.pcd"
    from placement.scene.io import scene_to_dict

    out = scene_to_dict(scene, relative_to=tmp_path)
    assert out["obstacle_cloud"] == {"file": "room.pcd", "voxel": 0.05}
    assert parse_scene(out, tmp_path).cloud.boxes.tolist() == scene.cloud.boxes.tolist()
    for bad, words in (
        ({"file": "room.pcd", "voxel": 5.0}, "voxel must be within"),
        ({"file": "nowhere.pcd"}, "cannot read the point cloud"),
        ({"file": "room.pcd", "size": 1}, "unknown key 'obstacle_cloud.size'"),
    ):
        doc["obstacle_cloud"] = bad
        with pytest.raises(SceneError, match=words) as err:
            parse_scene(doc, tmp_path)
        assert "\n" not in str(err.value)


def test_load_cloud_refuses_too_many_boxes(tmp_path, monkeypatch):
    import placement.scene.cloud as cloud

    monkeypatch.setattr(cloud, "MAX_CLOUD_BOXES", 3)
    pts = np.array([[0.0, 0.0, 1.0], [0.06, 0, 1], [0.12, 0, 1], [0.18, 0, 1.0]])  # four 5 cm columns
    (tmp_path / "c.pcd").write_bytes(pcd(pts, "ascii"))
    with pytest.raises(CloudError, match="4 boxes of 0.05 m voxels, more than the 3 allowed"):
        load_cloud(tmp_path / "c.pcd")
    assert len(load_cloud(tmp_path / "c.pcd", 0.5).boxes) == 1
