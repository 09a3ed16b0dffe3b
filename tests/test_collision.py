"""The scene collision checker against an independent oracle: plain coal calls on every shape pair.

The oracle builds everything itself: the robot's shapes with ``pinocchio.buildGeomFromUrdf``, their world
poses from pinocchio's placements and the base pose, the scene's shapes from the scene model (every
occupancy cell, not only those near the robot), the self pairs from the SRDF and the kinematic tree, and
then calls ``coal.collide`` / ``coal.distance`` on every pair.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest
from support.collision import scene_doc, with_occupancy
from support.robots import random_configs

import placement
from placement.collision import CLEARANCE_CAP, SceneCollision
from placement.planning import parse_scene

HEIGHT = 3.0  # the documented height of polygon prisms and occupancy cells [m]


# -- the oracle ---------------------------------------------------------------------------------------


def rz(yaw: float, centre) -> np.ndarray:
    T = np.eye(4)
    T[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    T[:3, 3] = centre
    return T


def oracle_scene(scene) -> list[tuple[str, object, np.ndarray]]:
    """(name, coal shape, world pose) of every obstacle, object and occupied cell (convex polygons only)."""
    out = []
    for ob in scene.obstacles:
        s = ob.shape
        if hasattr(s, "points"):
            pts = coal.StdVec_Vec3s()
            pts.extend([np.array([x, y, z]) for z in (0.0, HEIGHT) for x, y in s.points])
            out.append((ob.name, coal.Convex.convexHull(pts, False, None), np.eye(4)))
        elif hasattr(s, "radius"):
            out.append((ob.name, coal.Cylinder(s.radius, s.height), rz(0.0, s.center)))
        else:
            out.append((ob.name, coal.Box(*s.size), rz(s.yaw, s.center)))
    for o in scene.objects:
        out.append((o.name, coal.Box(*o.size), rz(o.yaw, o.position)))
    occ = scene.occupancy
    if occ is not None and occ.arm_height is not None:
        h = occ.arm_height
        for r, c in zip(*np.nonzero(occ.occupied)):
            centre = [occ.origin[0] + (c + 0.5) * occ.resolution, occ.origin[1] + (r + 0.5) * occ.resolution, h / 2]
            out.append((f"occupancy[{r},{c}]", coal.Box(occ.resolution, occ.resolution, h), rz(0.0, centre)))
    return out


def below(model, joints) -> set[int]:
    """Joints ``joints`` and all their descendants."""
    out = set()
    for j in range(1, model.njoints):
        k = j
        while k > 0 and k not in joints:
            k = model.parents[k]
        if k > 0:
            out.add(j)
    return out


class Oracle:
    def __init__(self, robot, arm: str, dirs: list[str], drop_links=()):
        model = robot.model
        geom = pin.buildGeomFromUrdf(model, str(robot.urdf_path), pin.GeometryType.COLLISION, package_dirs=dirs)
        for name in [o.name for o in geom.geometryObjects if model.frames[o.parentFrame].name in drop_links]:
            geom.removeGeometryObject(name)
        self.robot, self.arm, self.geom, self.model = robot, arm, geom, model
        self.names = [model.frames[o.parentFrame].name for o in geom.geometryObjects]
        a = robot.arm(arm)
        self.q0 = robot.reference_q()
        for other in robot.arms:
            self.q0 = robot.full_q(other, robot.arm(other).idle, self.q0)
        moved = below(model, set(a.joint_ids))
        hand = below(model, {a.joint_ids[-1], model.frames[model.getFrameId(a.tip_frame)].parentJoint})
        joints = [o.parentJoint for o in geom.geometryObjects]
        self.gripper = [j in hand for j in joints]
        self.data, self.gdata = model.createData(), pin.GeometryData(geom)
        pin.framesForwardKinematics(model, self.data, self.q0)
        self.base = self.data.oMf[robot.base_frame_id].homogeneous.copy()
        geom.addAllCollisionPairs()
        if robot.srdf_path is not None:
            pin.removeCollisionPairs(model, geom, str(robot.srdf_path))
        home = self.placements(self.q0, np.eye(4) @ self.base)
        self.pairs = []
        for cp in geom.collisionPairs:
            i, j = cp.first, cp.second
            ji, jj = joints[i], joints[j]
            if ji == jj or model.parents[ji] == jj or model.parents[jj] == ji or (ji not in moved and jj not in moved):
                continue
            if not self.collide(i, home[i], j, home[j]):
                self.pairs.append((i, j))

    def placements(self, q, to_world) -> list[coal.Transform3s]:
        pin.updateGeometryPlacements(self.model, self.data, self.geom, self.gdata, q)
        Ts = [to_world @ np.linalg.inv(self.base) @ M.homogeneous for M in self.gdata.oMg]
        return [coal.Transform3s(T[:3, :3], T[:3, 3]) for T in Ts]

    def collide(self, i, Ti, j, Tj, other=None, margin=0.0) -> bool:
        req = coal.CollisionRequest()
        req.security_margin = margin
        g2 = self.geom.geometryObjects[j].geometry if other is None else other
        return bool(coal.collide(self.geom.geometryObjects[i].geometry, Ti, g2, Tj, req, coal.CollisionResult()))

    def distance(self, i, Ti, j, Tj, other=None) -> float:
        g2 = self.geom.geometryObjects[j].geometry if other is None else other
        return coal.distance(
            self.geom.geometryObjects[i].geometry, Ti, g2, Tj, coal.DistanceRequest(), coal.DistanceResult()
        )

    def check(self, pieces, qs, base, grasped=None, padding=0.0) -> tuple[bool, float, dict]:
        """(free, smallest distance, {colliding pair name: its distances at the poses where it collides})."""
        W = rz(base[2], (base[0], base[1], 0.0))
        best, hits = np.inf, {}
        for q in qs:
            Ts = self.placements(self.robot.full_q(self.arm, q, self.q0), W)
            for i, Ti in enumerate(Ts):
                for name, shape, P in pieces:
                    if self.gripper[i] and name == grasped:
                        continue
                    Tp = coal.Transform3s(P[:3, :3], P[:3, 3])
                    d = self.distance(i, Ti, None, Tp, shape)
                    best = min(best, d)
                    if self.collide(i, Ti, None, Tp, shape, padding):
                        hits.setdefault(f"{self.names[i]} vs {name}", []).append(d)
            for i, j in self.pairs:
                d = self.distance(i, Ts[i], j, Ts[j])
                best = min(best, d)
                if self.collide(i, Ts[i], j, Ts[j]):
                    hits.setdefault(f"{self.names[i]} vs {self.names[j]}", []).append(d)
                    hits.setdefault(f"{self.names[j]} vs {self.names[i]}", []).append(d)
        return not hits, best, hits


def compare(checker, oracle, pieces, arm, qs, base, grasped=None, padding=0.0):
    got = checker.check(arm, qs, base, grasped)
    free, best, hits = oracle.check(pieces, qs, base, grasped, padding)
    assert got.free == free, (got, sorted(hits))
    if free:
        assert got.clearance_m == pytest.approx(min(best, CLEARANCE_CAP), abs=1e-6)
        assert (got.culprit is None) == (best >= CLEARANCE_CAP)
    else:
        assert got.culprit in hits
        assert min(abs(got.clearance_m - d) for d in hits[got.culprit]) < 1e-6
        assert got.clearance_m < padding or got.clearance_m <= 1e-9
    return got


def placements(robot, arm, rng, n, table_x, standoff):
    """n (qs (2, dof), base) with the base facing the table, the arm random, its pre-pose 0.1 rad away."""
    a = robot.arm(arm)
    Q = random_configs(a, n, rng)
    return [
        (
            np.array([q, np.clip(q + rng.normal(0, 0.1, a.dof), a.lower, a.upper)]),
            (table_x - 0.3 - rng.uniform(*standoff), rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4)),
        )
        for q in Q
    ]


# -- PR2 ----------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def pr2_scene():
    return with_occupancy(parse_scene(scene_doc("pr2", 1.0)))


@pytest.mark.slow
def test_pr2_decisions_and_clearances_equal_plain_coal(pr2, pr2_scene):
    """Random arm configurations at bases in front of a table: same verdicts, same clearance below the cap."""
    checker = SceneCollision(pr2, pr2_scene)
    pieces = oracle_scene(pr2_scene)
    outcomes = []
    for arm, seed in (("right", 3), ("left", 4)):
        oracle = Oracle(pr2, arm, [str(p) for p in Path(pr2.urdf_path).resolve().parents])
        for qs, base in placements(pr2, arm, np.random.default_rng(seed), 14, 1.0, (0.35, 0.6)):
            outcomes.append(compare(checker, oracle, pieces, arm, qs, base, grasped="cup_1"))
    free = [o for o in outcomes if o.free]
    # not vacuous: both verdicts, scene and self culprits, clearances measured below the cap
    assert 3 <= len(free) < len(outcomes)
    assert any(o.clearance_m < CLEARANCE_CAP for o in free)
    culprits = [o.culprit.split(" vs ")[1] for o in outcomes if not o.free]
    assert any(
        c in {"table_1", "tilted_crate", "pillar", "cup_1", "box_2"} or c.startswith("occupancy") for c in culprits
    )
    assert any(c.endswith("_link") for c in culprits)


@pytest.mark.slow
def test_pr2_padding_equals_coal_security_margin(pr2, pr2_scene):
    checker = SceneCollision(pr2, pr2_scene, padding=0.05)
    oracle = Oracle(pr2, "right", [str(p) for p in Path(pr2.urdf_path).resolve().parents])
    pieces = oracle_scene(pr2_scene)
    got = [
        compare(checker, oracle, pieces, "right", qs, base, padding=0.05)
        for qs, base in placements(pr2, "right", np.random.default_rng(11), 10, 1.0, (0.35, 0.6))
    ]
    assert any(not g.free and g.clearance_m > 0 for g in got)  # a pair within the padding, not touching


# -- ARMAR-6 (its meshes are not shipped: the test writes a cube for each) ------------------------------


def cube_stl(path: Path, half: float) -> None:
    """A binary STL cube of edge 2 half [m] centred at the origin."""
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", len(faces)))
        for a, b, c in faces:
            f.write(struct.pack("<12fH", 0, 0, 0, *v[a], *v[b], *v[c], 0))


def armar6_meshes(urdf: Path, folder: Path, skip=()) -> list[str]:
    """Write a 0.12 m cube for every collision mesh of the URDF (but those of links in ``skip``)
    under ``folder`` as a ROS package; returns the links written."""
    text = urdf.read_text()
    written = []
    for link, body in re.findall(r'<link name="([^"]+)"(.*?)</link>', text, re.S):
        for name in re.findall(r'<collision>.*?filename="package://([^"]+)"', body, re.S):
            if link not in skip:
                cube_stl(folder / name, 0.06)
                written.append(link)
    return written


@pytest.mark.slow
def test_armar6_decisions_and_clearances_equal_plain_coal(armar6, tmp_path):
    armar6_meshes(armar6.urdf_path, tmp_path)
    scene = with_occupancy(parse_scene(scene_doc(str(armar6.source), 1.1)))
    checker = SceneCollision(armar6, scene, package_dirs=[tmp_path])
    oracle = Oracle(armar6, "right", [str(tmp_path)])
    assert len(checker.geometry.names) == len(oracle.names) > 40
    pieces = oracle_scene(scene)
    got = [
        compare(checker, oracle, pieces, "right", qs, base, grasped="box_2")
        for qs, base in placements(armar6, "right", np.random.default_rng(2), 25, 1.1, (0.3, 0.6))
    ]
    assert 0 < sum(g.free for g in got) < len(got)
    assert any(g.free and g.clearance_m < CLEARANCE_CAP for g in got)


def test_armar6_missing_meshes_warn_and_the_rest_is_checked(armar6_preset, tmp_path):
    """Meshes of some links missing: one warning naming them; the check equals coal on the shapes that loaded."""
    from placement.collision import CollisionGeometryWarning

    robot = placement.load_robot(armar6_preset)  # a fresh robot: its geometry is not cached yet
    lost = ("torso", "Hand R Palm")
    armar6_meshes(robot.urdf_path, tmp_path, skip=lost)
    scene = parse_scene(scene_doc(str(armar6_preset), 1.1))
    with pytest.warns(CollisionGeometryWarning, match="torso, Hand R Palm") as record:
        checker = SceneCollision(robot, scene, package_dirs=[tmp_path])
    assert len(record) == 1
    full = tmp_path / "full"
    armar6_meshes(robot.urdf_path, full)
    oracle = Oracle(robot, "right", [str(full)], drop_links=lost)
    assert sorted(checker.geometry.names) == sorted(oracle.names)
    pieces = oracle_scene(scene)
    for qs, base in placements(robot, "right", np.random.default_rng(6), 8, 1.1, (0.3, 0.6)):
        compare(checker, oracle, pieces, "right", qs, base)
