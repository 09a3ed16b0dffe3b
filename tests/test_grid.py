"""The 6D grid: yaw-equivariant orientation coordinates and bin conventions (docs/maps.md)."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from placement import Grid
from placement.kernels.grid import pitch_bin, wrap_bin, zyx_angles
from placement.maps.grid import pose_from_zyx

GRID = Grid(origin=(-1.2, -1.1, -0.3), resolution=0.05, shape=(48, 44, 40, 20, 9, 20))


def Rz(a: float) -> np.ndarray:
    """(4, 4) rotation about z; entries of the z row/column are exact 0 and 1."""
    c, s = math.cos(a), math.sin(a)
    T = np.eye(4)
    T[:2, :2] = [[c, -s], [s, c]]
    return T


def random_poses(rng, n: int, lo=(-1.0, -0.9, -0.2), hi=(1.0, 0.9, 1.6)) -> np.ndarray:
    T = np.zeros((n, 4, 4))
    for i in range(n):
        T[i, :3, :3] = pin.Quaternion(*(rng.normal(size=4))).normalized().toRotationMatrix()
    T[:, :3, 3] = rng.uniform(lo, hi, size=(n, 3))
    T[:, 3, 3] = 1.0
    return T


def unravel(flat) -> np.ndarray:
    return np.stack(np.unravel_index(np.asarray(flat), GRID.shape), axis=-1)


def orientation_bins(T, shape=GRID.shape):
    yaw, pitch, roll = zyx_angles(np.ascontiguousarray(T))
    return wrap_bin(yaw, shape[3]), pitch_bin(pitch, shape[4]), wrap_bin(roll, shape[5])


# --------------------------------------------------------------------------------------------


def test_zyx_angles_match_pinocchio_rpy():
    rng = np.random.default_rng(0)
    for T in random_poses(rng, 300):
        yaw, pitch, roll = zyx_angles(T)
        assert -math.pi / 2 <= pitch <= math.pi / 2
        np.testing.assert_allclose(pin.rpy.rpyToMatrix(roll, pitch, yaw), T[:3, :3], atol=1e-12)
        np.testing.assert_allclose(pin.rpy.matrixToRpy(T[:3, :3]), [roll, pitch, yaw], atol=1e-9)


def test_pose_from_zyx_matches_pinocchio():
    rng = np.random.default_rng(1)
    n = 200
    yaw = rng.uniform(-math.pi, math.pi, n)
    pitch = rng.uniform(-math.pi / 2, math.pi / 2, n)
    roll = rng.uniform(-math.pi, math.pi, n)
    pos = rng.normal(size=(n, 3))
    T = pose_from_zyx(pos, yaw, pitch, roll)
    assert T.shape == (n, 4, 4)
    for i in range(n):
        np.testing.assert_allclose(T[i, :3, :3], pin.rpy.rpyToMatrix(roll[i], pitch[i], yaw[i]), atol=1e-14)
        np.testing.assert_array_equal(T[i, :3, 3], pos[i])
        np.testing.assert_array_equal(T[i, 3], [0, 0, 0, 1])
        np.testing.assert_allclose(zyx_angles(T[i]), (yaw[i], pitch[i], roll[i]), atol=1e-9)


@pytest.mark.parametrize("n_yaw", [20, 100])
def test_yaw_equivariance(n_yaw):
    """R -> Rz(k dyaw) R shifts only the yaw bin by +k; positions rotate with the base."""
    grid = Grid(origin=(-1.5, -1.5, -0.3), resolution=0.05, shape=(60, 60, 40, n_yaw, 9, 20))
    rng = np.random.default_rng(n_yaw)
    poses = random_poses(rng, 200, lo=(-1.0, -1.0, -0.2), hi=(1.0, 1.0, 1.6))
    base = grid.index(poses)
    assert np.all(base >= 0)
    b = np.stack(np.unravel_index(base, grid.shape), axis=-1)
    shifted_yaw_seen = set()
    for k in list(range(-3, 4)) + [n_yaw // 2, n_yaw - 1, int(rng.integers(0, n_yaw))]:
        a = k * 2 * math.pi / n_yaw
        R = Rz(a)
        rotated = R @ poses
        # orientation: exactly the same pitch/roll angles, yaw + a
        for T, Tr in zip(poses, rotated):
            y0, p0, r0 = zyx_angles(T)
            y1, p1, r1 = zyx_angles(Tr)
            assert (p1, r1) == (p0, r0)
            assert math.remainder(y1 - y0 - a, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
            assert pitch_bin(p1, 9) == pitch_bin(p0, 9) and wrap_bin(r1, 20) == wrap_bin(r0, 20)
            assert wrap_bin(y1, n_yaw) == (wrap_bin(y0, n_yaw) + k) % n_yaw
        idx = np.stack(np.unravel_index(grid.index(rotated), grid.shape), axis=-1)
        np.testing.assert_array_equal(idx[:, 3], (b[:, 3] + k) % n_yaw)
        np.testing.assert_array_equal(idx[:, 4:], b[:, 4:])
        np.testing.assert_array_equal(idx[:, 2], b[:, 2])  # z unchanged
        # x, y: the rotated position's cell
        p = poses[:, :3, 3] @ R[:3, :3].T
        np.testing.assert_allclose(rotated[:, :3, 3], p, atol=1e-15)
        want_xy = np.floor((p[:, :2] - grid.origin_array[:2]) / grid.resolution).astype(int)
        np.testing.assert_array_equal(idx[:, :2], want_xy)
        # the position really moved for k != 0 (the check is not vacuous)
        if k % n_yaw:
            assert np.any(idx[:, :2] != b[:, :2])
        shifted_yaw_seen.add(k % n_yaw)
    assert len(shifted_yaw_seen) > 5


def test_yaw_equivariance_quarter_turn_maps_cells_exactly():
    """On a grid symmetric about the base centre, a 90 degree base turn maps cells to cells:
    (ix, iy) -> (ny - 1 - iy, ix), yaw + n_yaw / 4, everything else unchanged."""
    grid = Grid(origin=(-1.0, -1.0, 0.0), resolution=0.1, shape=(20, 20, 10, 20, 9, 20))
    rng = np.random.default_rng(3)
    poses = random_poses(rng, 300, lo=(-0.99, -0.99, 0.01), hi=(0.99, 0.99, 0.99))
    a = np.stack(np.unravel_index(grid.index(poses), grid.shape), axis=-1)
    R = np.eye(4)
    R[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]  # exact quarter turn
    b = np.stack(np.unravel_index(grid.index(R @ poses), grid.shape), axis=-1)
    # points exactly on a cell edge would be ambiguous; random ones are not
    np.testing.assert_array_equal(b[:, 0], 19 - a[:, 1])
    np.testing.assert_array_equal(b[:, 1], a[:, 0])
    np.testing.assert_array_equal(b[:, 2], a[:, 2])
    np.testing.assert_array_equal(b[:, 3], (a[:, 3] + 5) % 20)
    np.testing.assert_array_equal(b[:, 4:], a[:, 4:])


@pytest.mark.parametrize("n_pitch,n_roll", [(9, 20), (5, 8), (11, 36)])
def test_top_grasp_is_mid_bin(n_pitch, n_roll):
    """z pointing down: pitch 0 (centre of the middle pitch bin), roll +-pi (centre of bin n_roll/2)."""
    top = np.diag([1.0, -1.0, -1.0, 1.0])
    for a in np.linspace(-math.pi, math.pi, 37):
        T = Rz(a) @ top
        T[:3, 3] = (0.6, -0.2, 0.8)
        yaw, pitch, roll = zyx_angles(T)
        assert pitch == 0.0
        assert abs(roll) == math.pi
        assert math.remainder(yaw - a, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
        assert pitch_bin(pitch, n_pitch) == n_pitch // 2
        assert wrap_bin(roll, n_roll) == n_roll // 2
    # both signs of the wrap-around land in the same bin, and it is the bin centre
    assert wrap_bin(math.pi, n_roll) == wrap_bin(-math.pi, n_roll) == n_roll // 2
    assert wrap_bin(math.pi - 1e-9, n_roll) == wrap_bin(-math.pi + 1e-9, n_roll) == n_roll // 2
    droll = 2 * math.pi / n_roll
    assert wrap_bin(math.pi - 0.49 * droll, n_roll) == n_roll // 2
    assert wrap_bin(-math.pi + 0.49 * droll, n_roll) == n_roll // 2
    assert wrap_bin(math.pi - 0.51 * droll, n_roll) == n_roll // 2 - 1
    assert wrap_bin(-math.pi + 0.51 * droll, n_roll) == (n_roll // 2 + 1) % n_roll
    dpitch = math.pi / n_pitch
    assert pitch_bin(0.49 * dpitch, n_pitch) == pitch_bin(-0.49 * dpitch, n_pitch) == n_pitch // 2
    assert pitch_bin(0.51 * dpitch, n_pitch) == n_pitch // 2 + 1
    assert pitch_bin(-0.51 * dpitch, n_pitch) == n_pitch // 2 - 1


def test_top_grasp_cell_centre_is_the_top_grasp():
    """The centre of the top grasp's cell has the same orientation (yaw on a bin centre)."""
    top = np.diag([1.0, -1.0, -1.0, 1.0])
    dyaw = GRID.angle_steps[0]
    for k in range(GRID.shape[3]):
        T = Rz(k * dyaw) @ top
        flat = GRID.index(T)
        idx = unravel(flat)[0]
        assert tuple(idx[3:]) == (k, GRID.shape[4] // 2, GRID.shape[5] // 2)
        C = GRID.centre(flat)[0]
        np.testing.assert_allclose(C[:3, :3], T[:3, :3], atol=1e-12)


def test_bin_edges_and_ranges():
    n = 20
    w = 2 * math.pi / n
    assert wrap_bin(0.0, n) == 0
    assert wrap_bin(0.49 * w, n) == 0 and wrap_bin(-0.49 * w, n) == 0
    assert wrap_bin(0.51 * w, n) == 1 and wrap_bin(-0.51 * w, n) == n - 1
    assert wrap_bin(3 * w, n) == 3 and wrap_bin(-3 * w, n) == n - 3
    angles = np.random.default_rng(5).uniform(-math.pi, math.pi, 1000)
    bins = np.array([wrap_bin(x, n) for x in angles])
    assert bins.min() == 0 and bins.max() == n - 1
    # the bin centre is the nearest multiple of w (modulo 2 pi)
    np.testing.assert_array_equal(bins, np.round(angles / w).astype(int) % n)
    assert pitch_bin(-math.pi / 2, 9) == 0 and pitch_bin(math.pi / 2, 9) == 8
    pitches = np.random.default_rng(6).uniform(-math.pi / 2, math.pi / 2, 1000)
    np.testing.assert_array_equal(
        [pitch_bin(p, 9) for p in pitches], np.floor((pitches + math.pi / 2) / (math.pi / 9)).astype(int)
    )


def test_centre_maps_back_to_index():
    rng = np.random.default_rng(7)
    flat = rng.integers(0, GRID.size, 2000)
    # include the corners of every axis
    corners = np.ravel_multi_index(tuple(np.array([[0] * 6, [s - 1 for s in GRID.shape]]).T), GRID.shape)
    flat = np.concatenate([flat, corners])
    C = GRID.centre(flat)
    np.testing.assert_array_equal(GRID.index(C), flat)
    # centres sit half a cell from the lower corner
    idx = unravel(flat)
    np.testing.assert_allclose(C[:, :3, 3], GRID.origin_array + (idx[:, :3] + 0.5) * GRID.resolution, atol=1e-12)


def test_index_outside_is_minus_one():
    T = np.eye(4)
    T[:3, 3] = GRID.origin_array - 0.01
    assert GRID.index(T)[0] == -1
    T[:3, 3] = GRID.origin_array + np.array(GRID.shape[:3]) * GRID.resolution + 0.01
    assert GRID.index(T)[0] == -1
    T[:3, 3] = GRID.origin_array + 0.001
    assert GRID.index(T)[0] >= 0


def test_index_matches_slow_reference():
    """Grid.index against a direct numpy computation from pinocchio's rpy."""
    rng = np.random.default_rng(8)
    poses = random_poses(rng, 500)
    got = GRID.index(poses)
    for T, g in zip(poses, got):
        roll, pitch, yaw = pin.rpy.matrixToRpy(T[:3, :3])
        ipos = np.floor((T[:3, 3] - GRID.origin_array) / GRID.resolution).astype(int)
        n_yaw, n_pitch, n_roll = GRID.shape[3:]
        iyaw = int(round(yaw / (2 * math.pi / n_yaw))) % n_yaw
        ip = min(int((pitch + math.pi / 2) // (math.pi / n_pitch)), n_pitch - 1)
        ir = int(round(roll / (2 * math.pi / n_roll))) % n_roll
        assert g == np.ravel_multi_index((*ipos, iyaw, ip, ir), GRID.shape)


def test_pose_bins_match_a_slow_reference():
    """pose_bins (a step's poses in one call) against the same numpy computation from pinocchio's rpy:
    z bin (-1 outside the grid's heights), pitch and roll bins, and the yaw."""
    from placement.kernels.grid import pose_bins

    rng = np.random.default_rng(9)
    poses = random_poses(rng, 500, lo=(-1.0, -0.9, -0.6), hi=(1.0, 0.9, 2.2))  # some below and above
    n_pitch, n_roll = GRID.shape[4:]
    bins, yaws = pose_bins(poses, GRID.origin[2], GRID.resolution, GRID.shape[2], n_pitch, n_roll)
    outside = 0
    for T, b, y in zip(poses, bins, yaws):
        roll, pitch, yaw = pin.rpy.matrixToRpy(T[:3, :3])
        iz = math.floor((T[2, 3] - GRID.origin[2]) / GRID.resolution)
        iz = iz if 0 <= iz < GRID.shape[2] else -1
        outside += iz < 0
        ip = min(int((pitch + math.pi / 2) // (math.pi / n_pitch)), n_pitch - 1)
        ir = int(round(roll / (2 * math.pi / n_roll))) % n_roll
        assert b.tolist() == [iz, ip, ir]
        assert y == pytest.approx(yaw, abs=1e-12)
    assert 30 < outside < 470  # both inside and outside the heights are checked


def test_grid_rejects_bad_bins():
    import placement

    with pytest.raises(placement.GridError):
        Grid((0, 0, 0), 0.05, (2, 2, 2, 21, 9, 20))  # odd yaw count
    with pytest.raises(placement.GridError):
        Grid((0, 0, 0), 0.05, (2, 2, 2, 20, 8, 20))  # even pitch count
    with pytest.raises(placement.GridError):
        Grid((0, 0, 0), 0.05, (2, 2, 2, 20, 9, 19))  # odd roll count
    with pytest.raises(placement.GridError):
        Grid((0, 0, 0), -0.05, (2, 2, 2, 20, 9, 20))
