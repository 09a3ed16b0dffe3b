"""Self-collision pairs that are modelling artefacts, found as MoveIt's Setup Assistant finds them.

For each arm, :data:`SAMPLES` configurations drawn uniformly within its joint limits (seeded; the other
arms at home, the held joints as proposed) are tested: every pair of a shape the arm moves and any other
shape of the robot, except those the collision checker leaves out anyway (same or adjacent links, the
SRDF's disabled pairs, pairs already in contact at home). A bounding-sphere test comes first, then
``coal.collide`` on the meshes' convex hulls (10-100x faster; hulls apart means meshes apart), then on
the shapes themselves. A link pair colliding in >= :data:`THRESHOLD` of the samples
of an arm (e.g. meshes two joints apart that overlap in the URDF) would reject almost every IK solution;
``placement robots init`` writes it as ``ignore_collisions`` for the user to confirm.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from placement.collision.robot import (
    CollisionGeometryWarning,
    adjacent,
    convex_hull,
    load_geometry,
    moved_joints,
    transform,
)
from placement.robots.onboarding.reach import sample_configs
from placement.robots.preset import Robot

#: Configurations sampled per arm, and the fraction of them a pair must collide in to be ignored.
SAMPLES = 1000
THRESHOLD = 0.5


@dataclass(frozen=True)
class ArtefactPair:
    """Two links that collide in ``fraction`` of the random configurations of ``arm``."""

    links: tuple[str, str]
    fraction: float
    arm: str


def candidate_pairs(
    robot: Robot, geom: pin.GeometryModel, moved: set[int], home: list[pin.SE3]
) -> list[tuple[int, int]]:
    """Shape pairs (i, j) with a shape in ``moved`` that the collision checker would test: not on the same
    or adjacent links, not disabled by the SRDF, not in contact at the placements ``home``."""
    model = robot.model
    work = pin.GeometryModel()
    for o in geom.geometryObjects:
        work.addGeometryObject(o)
    work.addAllCollisionPairs()
    if robot.srdf_path is not None:
        pin.removeCollisionPairs(model, work, str(robot.srdf_path))
    req, res = coal.CollisionRequest(), coal.CollisionResult()
    objs = geom.geometryObjects
    out = []
    for cp in work.collisionPairs:
        i, j = cp.first, cp.second
        ji, jj = objs[i].parentJoint, objs[j].parentJoint
        if adjacent(model, ji, jj) or (ji not in moved and jj not in moved):
            continue
        res.clear()
        if not coal.collide(objs[i].geometry, transform(home[i]), objs[j].geometry, transform(home[j]), req, res):
            out.append((i, j))
    return out


def artefact_pairs(
    robot: Robot, samples: int = SAMPLES, seed: int = 0, threshold: float = THRESHOLD
) -> list[ArtefactPair]:
    """Link pairs colliding in >= ``threshold`` of ``samples`` random configurations of some arm (the
    largest fraction over the arms), most frequent first; none for a robot without collision shapes."""
    model = robot.model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CollisionGeometryWarning)
        geom, _ = load_geometry(robot, strict=False)
    objs = geom.geometryObjects
    names = [model.frames[o.parentFrame].name for o in objs]
    for o in objs:
        o.geometry.computeLocalAABB()
    centre = np.array([np.asarray(o.geometry.aabb_center) for o in objs]).reshape(-1, 3)
    radius = np.array([o.geometry.aabb_radius for o in objs], dtype=float)
    hulls = [convex_hull(o.geometry)[0] for o in objs]
    data, gdata = model.createData(), pin.GeometryData(geom)
    home_q = robot.reference_q()
    for name in robot.arms:
        home_q = robot.full_q(name, robot.arm(name).home, home_q)
    pin.updateGeometryPlacements(model, data, geom, gdata, home_q)
    home = [pin.SE3(M) for M in gdata.oMg]
    req, res = coal.CollisionRequest(), coal.CollisionResult()
    best: dict[tuple[str, str], ArtefactPair] = {}
    for k, arm in enumerate(robot.arms):
        a = robot.arm(arm)
        pairs = np.array(candidate_pairs(robot, geom, moved_joints(model, a.joint_ids), home), dtype=int)
        if not len(pairs):
            continue
        link_pairs = sorted({tuple(sorted((names[i], names[j]))) for i, j in pairs})
        index = {lp: n for n, lp in enumerate(link_pairs)}
        pair_link = np.array([index[tuple(sorted((names[i], names[j])))] for i, j in pairs])
        hits = np.zeros(len(link_pairs), dtype=int)
        for q in sample_configs(a.lower, a.upper, samples, seed + k):
            pin.updateGeometryPlacements(model, data, geom, gdata, robot.full_q(arm, q, home_q))
            R = np.array([M.rotation for M in gdata.oMg])
            world = np.einsum("gij,gj->gi", R, centre) + np.array([M.translation for M in gdata.oMg])
            near = (
                np.linalg.norm(world[pairs[:, 0]] - world[pairs[:, 1]], axis=1)
                <= radius[pairs[:, 0]] + radius[pairs[:, 1]]
            )
            hit = np.zeros(len(link_pairs), dtype=bool)
            for p in np.flatnonzero(near):
                if hit[pair_link[p]]:
                    continue
                i, j = int(pairs[p, 0]), int(pairs[p, 1])
                Ti, Tj = transform(gdata.oMg[i]), transform(gdata.oMg[j])
                res.clear()
                if not coal.collide(hulls[i], Ti, hulls[j], Tj, req, res):
                    continue
                res.clear()
                hit[pair_link[p]] = coal.collide(objs[i].geometry, Ti, objs[j].geometry, Tj, req, res)
            hits += hit
        for lp, h in zip(link_pairs, hits):
            if h >= threshold * samples and (lp not in best or h / samples > best[lp].fraction):
                best[lp] = ArtefactPair(lp, float(h / samples), arm)
    return sorted(best.values(), key=lambda p: (-p.fraction, p.links))
