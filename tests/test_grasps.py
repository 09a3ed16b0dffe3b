import math

import numpy as np

from placement.kernels.grid import zyx_angles
from placement.maps.grid import pose_from_zyx
from placement.planning.problems.grasps import place_candidates, top_grasps


def test_top_grasp_literal():
    # a 4 cm x 10 cm x 12 cm box at yaw 0: close across x (the narrow side), z down
    g = top_grasps((1.0, 2.0, 0.8), 0.0, (0.04, 0.10, 0.12))
    assert [c.name for c in g] == ["top", "top-flipped"]
    T = g[0].poses
    np.testing.assert_allclose(T[1, :3, 3], [1.0, 2.0, 0.86])
    np.testing.assert_allclose(T[0, :3, 3], [1.0, 2.0, 0.96])
    np.testing.assert_allclose(T[1, :3, 2], [0, 0, -1])  # approach down
    np.testing.assert_allclose(T[1, :3, 1], [1, 0, 0])  # closing across x
    np.testing.assert_allclose(g[1].poses[1, :3, 1], [-1, 0, 0])
    for c in g:
        R = c.poses[1, :3, :3]
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) > 0.999
        yaw, pitch, roll = zyx_angles(c.poses[1])
        assert abs(pitch) < 1e-12 and abs(abs(roll) - math.pi) < 1e-12
        np.testing.assert_allclose(pose_from_zyx(c.poses[1:, :3, 3], yaw, pitch, roll), c.poses[1:], atol=1e-12)


def test_narrow_side_follows_object_yaw():
    g = top_grasps((0, 0, 0.5), math.pi / 2, (0.10, 0.04, 0.1))  # narrow side is the object's y = world -x
    np.testing.assert_allclose(np.abs(g[0].poses[1, :3, 1]), [1, 0, 0], atol=1e-12)


def test_place_candidates():
    c = place_candidates((0.5, 0.5, 0.9), yaws=4)
    assert len(c) == 4
    ys = np.array([x.poses[1, :3, 1] for x in c])
    np.testing.assert_allclose(ys[:, :2], [[1, 0], [0, 1], [-1, 0], [0, -1]], atol=1e-12)
    assert all(np.allclose(x.poses[1, :3, 3], (0.5, 0.5, 0.9)) for x in c)


def test_place_candidates_from_yaw_list():
    c = place_candidates((0, 0, 1), yaws=[0.0, math.pi / 2])
    np.testing.assert_allclose(c[1].poses[1, :3, 1], [0, 1, 0], atol=1e-12)
