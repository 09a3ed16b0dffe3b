"""The example robots of examples/robots/urdf (so_arm_base, lift_telescope): they load with pinocchio
(model and collision shapes), have the joints and limits their headers describe, stand on a
``base_footprint`` frame on the floor, and their forward kinematics agree with a plain numpy walk of
the URDF's joint transforms."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest

ROOT = Path(__file__).resolve().parents[1]
URDFS = ROOT / "examples" / "robots" / "urdf"
SO_ARM = URDFS / "so_arm_base.urdf.xacro"
LIFT = URDFS / "lift_telescope.urdf"
SO_ARM_JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]
TELESCOPE = ["joint_arm_l3", "joint_arm_l2", "joint_arm_l1", "joint_arm_l0"]
WRIST = ["joint_wrist_yaw", "joint_wrist_pitch", "joint_wrist_roll"]


def urdf_text(path: Path) -> str:
    if path.suffix == ".xacro":
        xacro = pytest.importorskip("xacro")
        return str(xacro.process_file(str(path)).toxml())
    return path.read_text()


@pytest.fixture(scope="module", params=[SO_ARM, LIFT], ids=["so_arm_base", "lift_telescope"])
def robot(request):
    text = urdf_text(request.param)
    model = pin.buildModelFromXML(text)
    return request.param, text, model


def share() -> Path:
    from placement.robots.spec import share_dir

    return share_dir()


def geometry(model: pin.Model, text: str) -> pin.GeometryModel:
    return pin.buildGeomFromUrdfString(model, text, pin.GeometryType.COLLISION, package_dirs=[str(share())])


def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """URDF's fixed-axis roll-pitch-yaw: Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about the unit vector ``axis`` by ``angle`` [rad]."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def numpy_fk(text: str, link: str, q: dict[str, float]) -> np.ndarray:
    """4 x 4 pose of ``link`` in the root link's frame from the URDF's joints (0 for joints not in ``q``)."""
    joints = {j.find("child").get("link"): j for j in ET.fromstring(text).iter("joint")}
    chain = []
    while link in joints:
        chain.append(joints[link])
        link = joints[link].find("parent").get("link")
    T = np.eye(4)
    for j in reversed(chain):
        o = j.find("origin")
        step = np.eye(4)
        if o is not None:
            step[:3, :3] = rpy_matrix(*[float(v) for v in o.get("rpy", "0 0 0").split()])
            step[:3, 3] = [float(v) for v in o.get("xyz", "0 0 0").split()]
        motion = np.eye(4)
        value = q.get(j.get("name"), 0.0)
        if j.get("type") != "fixed":
            axis = np.array([float(v) for v in j.find("axis").get("xyz").split()])
            axis /= np.linalg.norm(axis)
            if j.get("type") == "prismatic":
                motion[:3, 3] = axis * value
            else:
                motion[:3, :3] = axis_angle(axis, value)
        T = T @ step @ motion
    return T


def config(model: pin.Model, values: dict[str, float]) -> np.ndarray:
    q = pin.neutral(model)
    for name, v in values.items():
        q[model.idx_qs[model.getJointId(name)]] = v
    return q


def frame_pose(model: pin.Model, frame: str, q: np.ndarray) -> np.ndarray:
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return np.asarray(data.oMf[model.getFrameId(frame)].homogeneous)


def joint_kind(model: pin.Model, name: str) -> str:
    return str(model.joints[model.getJointId(name)].shortname())


def test_loads_with_collision_boxes_and_visual_meshes(robot):
    path, text, model = robot
    geom = geometry(model, text)
    assert geom.ngeoms >= 6
    # every shape is a box (no mesh to slow collision checks down)
    assert all(isinstance(g.geometry, coal.Box) for g in geom.geometryObjects)
    root = ET.fromstring(text)
    for link in root.iter("link"):
        for box in link.iterfind("collision/geometry/box"):
            assert min(float(v) for v in box.get("size").split()) > 0, link.get("name")
        if link.find("inertial") is not None:
            m = float(link.find("inertial/mass").get("value"))
            assert m > 0, link.get("name")
    # every visual mesh resolves in example-robot-data's share folder
    for mesh in root.iter("mesh"):
        name = mesh.get("filename")
        assert name.startswith("package://example-robot-data/"), name
        assert (share() / name.removeprefix("package://")).is_file(), name
    assert not list(root.iter("mimic"))


def test_base_footprint_on_the_floor_and_nothing_below_it(robot):
    path, text, model = robot
    frame = model.frames[model.getFrameId("base_footprint")]
    assert frame.parentJoint == 0  # on the root: it moves with the base only
    pose = frame_pose(model, "base_footprint", pin.neutral(model))
    np.testing.assert_allclose(pose, np.eye(4), atol=1e-12)
    geom = geometry(model, text)
    data, gdata = model.createData(), pin.GeometryData(geom)
    pin.updateGeometryPlacements(model, data, geom, gdata, pin.neutral(model))
    # a box's lowest point: its centre's z less the half sides projected on z
    lowest = min(
        gdata.oMg[i].translation[2] - np.abs(gdata.oMg[i].rotation[2]) @ g.geometry.halfSide
        for i, g in enumerate(geom.geometryObjects)
    )
    assert lowest >= -1e-9  # no shape below the floor at neutral


def test_pinocchio_fk_matches_numpy_walk_of_the_urdf(robot):
    path, text, model = robot
    tip = "gripper_frame_link" if path == SO_ARM else "link_grasp_center"
    rng = np.random.default_rng(0)
    names = [model.names[i] for i in range(1, model.njoints)]
    for _ in range(20):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        values = {n: float(q[model.idx_qs[model.getJointId(n)]]) for n in names}
        np.testing.assert_allclose(frame_pose(model, tip, q), numpy_fk(text, tip, values), atol=1e-9)


def test_so_arm_joints_limits_and_height():
    model = pin.buildModelFromXML(urdf_text(SO_ARM))
    names = [model.names[i] for i in range(1, model.njoints)]
    assert names == SO_ARM_JOINTS + ["gripper"]
    assert all(joint_kind(model, n).startswith("JointModelR") for n in names)
    for n in SO_ARM_JOINTS:
        i = model.idx_qs[model.getJointId(n)]
        assert -3.2 < model.lowerPositionLimit[i] < 0 < model.upperPositionLimit[i] < 3.2
    # the shoulder_lift axis on the 0.65 m column: 0.767 m up, in front of the base's centre
    shoulder = frame_pose(model, "upper_arm_link", pin.neutral(model))[:3, 3]
    assert shoulder[2] == pytest.approx(0.65 + 0.1166, abs=1e-3)
    assert 0.1 < shoulder[0] < 0.2


def test_so_arm_reaches_a_045_m_table_top_down():
    """Uniform joint samples with the approach (gripper_frame_link's z) within 15 deg of straight down
    reach TCP heights of objects on a 0.45 m table (0.47-0.52 m) and of their pre-grasps (0.62-0.67 m)."""
    model = pin.buildModelFromXML(urdf_text(SO_ARM))
    data = model.createData()
    fid = model.getFrameId("gripper_frame_link")
    rng = np.random.default_rng(1)
    heights = []
    for _ in range(20000):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.framesForwardKinematics(model, data, q)
        M = data.oMf[fid]
        if M.rotation[2, 2] < -math.cos(math.radians(15)):
            heights.append(M.translation[2])
    h = np.array(heights)
    assert ((h > 0.47) & (h < 0.52)).sum() > 20
    assert ((h > 0.62) & (h < 0.67)).sum() > 20


def test_lift_telescope_joints_and_limits():
    model = pin.buildModelFromXML(LIFT.read_text())
    names = [model.names[i] for i in range(1, model.njoints)]
    fingers = ["joint_gripper_finger_left", "joint_gripper_finger_right"]
    assert names == ["joint_lift"] + TELESCOPE + WRIST + fingers

    def limits(n):
        j = model.getJointId(n)
        i = model.idx_qs[j]
        return model.lowerPositionLimit[i], model.upperPositionLimit[i], model.velocityLimit[model.idx_vs[j]]

    assert joint_kind(model, "joint_lift") == "JointModelPZ"
    assert limits("joint_lift") == pytest.approx((0.0, 1.1, 0.15))
    for n in TELESCOPE:
        assert joint_kind(model, n).startswith("JointModelP")
        assert limits(n) == pytest.approx((0.0, 0.13, 0.1))
    for n in WRIST:
        assert joint_kind(model, n).startswith("JointModelR")
        lo, hi, v = limits(n)
        assert lo < 0 < hi and v > 0
    total = sum(i.mass for i in model.inertias)
    assert 15 < total < 40  # [kg] a Stretch weighs about 24 kg
    for inertia in model.inertias[1:]:
        ev = np.linalg.eigvalsh(inertia.inertia)
        assert ev.min() > 0 and ev.max() <= ev.sum() - ev.max() + 1e-12  # triangle inequality


def test_lift_raises_and_telescope_extends_the_tip():
    """Moving the lift by d moves the TCP by (0, 0, d); extending the telescope joints by d_k moves it
    by sum(d_k) along the arm's horizontal direction (-y); the orientation does not change."""
    model = pin.buildModelFromXML(LIFT.read_text())
    rng = np.random.default_rng(2)
    names = ["joint_lift"] + TELESCOPE + WRIST
    for _ in range(10):
        values = {n: float(rng.uniform(*limits)) for n, limits in zip(names, bounds(model, names))}
        base = frame_pose(model, "link_grasp_center", config(model, values))
        up = dict(values, joint_lift=values["joint_lift"] + 0.3 if values["joint_lift"] < 0.8 else 0.1)
        d = up["joint_lift"] - values["joint_lift"]
        lifted = frame_pose(model, "link_grasp_center", config(model, up))
        np.testing.assert_allclose(lifted[:3, 3] - base[:3, 3], [0, 0, d], atol=1e-12)
        np.testing.assert_allclose(lifted[:3, :3], base[:3, :3], atol=1e-12)
        out = dict(values, **{n: float(rng.uniform(0, 0.13)) for n in TELESCOPE})
        travel = sum(out[n] - values[n] for n in TELESCOPE)
        extended = frame_pose(model, "link_grasp_center", config(model, out))
        np.testing.assert_allclose(extended[:3, 3] - base[:3, 3], [0, -travel, 0], atol=1e-12)
        np.testing.assert_allclose(extended[:3, :3], base[:3, :3], atol=1e-12)
    # all joints at their limits: lift travel 1.1 m, telescope 4 x 0.13 = 0.52 m
    lo = frame_pose(model, "link_grasp_center", pin.neutral(model))[:3, 3]
    hi = frame_pose(model, "link_grasp_center", config(model, {"joint_lift": 1.1, **dict.fromkeys(TELESCOPE, 0.13)}))
    np.testing.assert_allclose(hi[:3, 3] - lo, [0, -0.52, 1.1], atol=1e-12)


def bounds(model: pin.Model, names: list[str]) -> list[tuple[float, float]]:
    out = []
    for n in names:
        i = model.idx_qs[model.getJointId(n)]
        out.append((float(model.lowerPositionLimit[i]), float(model.upperPositionLimit[i])))
    return out


def test_a_xacro_named_by_a_relative_path_expands_and_gives_collision_shapes(monkeypatch):
    """The description is read from the caller's directory (the xacro child runs in the file's own);
    the collision model of a xacro robot is built from its expansion, not from the raw xacro."""
    from placement.collision.robot import usable_urdf
    from placement.robots.description import read_description

    monkeypatch.chdir(ROOT)
    rel = SO_ARM.relative_to(ROOT)
    text = read_description(rel, "test")
    assert b"<robot" in text and b"${" not in text
    urdf, lost, missing = usable_urdf(rel, [])
    root = ET.fromstring(urdf)
    assert not lost and not missing
    assert len(root.findall("link/collision")) >= 6
