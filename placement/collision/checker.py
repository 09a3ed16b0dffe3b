"""Is an arm trajectory at a base placement free of collisions with the scene and with the robot itself?

The robot stands with its base frame on the floor at (x, y), heading yaw; the checked arm takes each
configuration of the trajectory, the preset's fixed joints keep their values, every other arm is at
idle configuration (the preset's ``idle``, by default home) and every other joint at pinocchio's neutral value.

Pairs checked (coal, on the URDF's collision shapes, see :mod:`placement.collision.robot`):

* robot-scene: every robot shape against every scene piece (:mod:`placement.collision.scene`), except
  the gripper (the shapes moved by the arm's last joint or carrying its tip frame) against the
  ``grasped`` object: it is being grasped, or held in a place step. The rest of the arm is checked
  against it. A pair collides when its distance is below ``padding`` [m].
* floor: every shape moved by the arm, and the held object, against the floor (z = 0): see
  :mod:`placement.collision.floor`.
* self: every shape moved by the arm against every other shape, except shapes on the same or adjacent
  links, the SRDF's disabled pairs and pairs already in contact with every arm idle (they touch by
  design or through the model's slack). A pair collides when the shapes overlap (no padding).

Speed: each robot shape is bounded by a sphere, each scene piece by an axis-aligned box; a pair whose
bound distance exceeds what it could change is never given to coal. Overlapping bounds are tested with
coal's boolean collision first (most likely pairs first, stopping at the first collision); only a free
trajectory gets distance queries, in order of the bound, until the bound exceeds the best distance.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Collection, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.collision.bounds import base_matrix, influence_box, model_aabb
from placement.collision.floor import floor_collision
from placement.collision.held import HeldCheck
from placement.collision.pairs import candidate_pairs
from placement.collision.robot import ArmShapes, moved_joints, robot_geometry
from placement.collision.scene import OccupancyCells, PieceGrid, SceneShape, eroded, scene_shapes
from placement.collision.tables import CollisionResult, Instances, Operand, Pairs, ScenePieces
from placement.errors import PlacementError
from placement.robots import Robot
from placement.robots.model_cache import frame_id

if TYPE_CHECKING:
    from placement.collision.held import Held
    from placement.scene import Scene

#: Distances are measured up to this [m]; a free trajectory farther from everything reports it.
CLEARANCE_CAP = 0.2

#: [m] how far two grippers' shapes may lie apart in the TCP frame and still be twins (see
#: SceneCollision.gripper_twin): forward kinematics' rounding, a millionth of any screen's slack.
TWIN_TOL_M = 1e-9

#: Scenes of at least this many pieces are bucketed on a grid (fewer: every piece is bounded per check).
GRID_PIECES = 64

#: [m] the grid window's margin beyond the reach (rounding of the frame changes).
GRID_SLACK = 1e-6

#: [m] a convex hull this much farther than the best distance so far is not measured exactly.
HULL_SLACK = 1e-5


class SceneCollision:
    """Collision checker of one robot in one scene (see the module doc).

    Args:
        robot: the robot (its collision shapes load once per robot object; missing meshes warn).
        scene: a :class:`~placement.scene.Scene` (obstacles, tables, objects, occupancy map).
        padding: robot-scene pairs closer than this [m] collide.
        clearance_cap: distances are measured up to this [m].
        package_dirs: extra folders holding the URDF's ``package://`` meshes.
    """

    def __init__(
        self,
        robot: Robot,
        scene: Scene,
        padding: float = 0.0,
        clearance_cap: float = CLEARANCE_CAP,
        package_dirs: Sequence[Path | str] = (),
    ) -> None:
        if not (np.isfinite(padding) and padding >= 0) or not (np.isfinite(clearance_cap) and clearance_cap > 0):
            raise PlacementError(
                f"collision check: padding ({padding}) must be >= 0 and clearance_cap ({clearance_cap}) > 0 [m]"
            )
        self.robot = robot
        self.geometry = robot_geometry(robot, package_dirs)
        self.padding, self.cap = float(padding), float(clearance_cap)
        self._data = robot.model.createData()
        self._gdata = pin.GeometryData(self.geometry.geom)
        self._scene_req = coal.CollisionRequest()
        self._scene_req.security_margin = self.padding
        self._self_req = coal.CollisionRequest()
        self._cres, self._dreq, self._dres = coal.CollisionResult(), coal.DistanceRequest(), coal.DistanceResult()
        self._grippers: dict[str, tuple[npt.NDArray[np.int_], npt.NDArray[np.float64]] | None] = {}
        self._twins: dict[str, str | None] = {}
        home = self.geometry.home_placements
        self._home_R = np.array([M.rotation for M in home]).reshape(-1, 3, 3)
        self._home_t = np.array([M.translation for M in home]).reshape(-1, 3)
        self.update(scene)

    #: Bucket the scene pieces on a coarse grid (see :class:`~placement.collision.scene.PieceGrid`) when
    #: there are at least :data:`GRID_PIECES` of them, so that a check looks only at those near the robot.
    prefilter = True

    def update(self, scene: Scene) -> None:
        """Take the scene's obstacles, objects and occupancy map as they are now (after moves)."""
        shapes: list[SceneShape] = scene_shapes(scene)
        objects = [o.name for o in scene.objects]
        names = set(objects)
        object_of: list[str | None] = [s.name if s.name in names else None for s in shapes]
        aabb = np.array([s.aabb for s in shapes]).reshape(-1, 2, 3)
        occ = getattr(scene, "occupancy", None)
        # a 2D map is the base's; its cells enter the arm's model only with a height the user gave
        height = getattr(occ, "arm_height", None)
        cells = OccupancyCells(occ, height) if occ is not None and height is not None else None
        grid = PieceGrid(aabb, self._tilt()) if self.prefilter and len(shapes) >= GRID_PIECES else None
        # all or nothing: a scene the check cannot take leaves the checker as it was
        self.shapes, self.objects, self._object_of, self._aabb, self.cells, self._grid = (
            shapes,
            objects,
            object_of,
            aabb,
            cells,
            grid,
        )

    def _tilt(self) -> float | None:
        """How far the base frame's z leaves the model's z (0: a turn about z; None: more than 1e-9)."""
        R = self.geometry.base_in_model[:3, :3]
        tilt = float(max(abs(R[2, 0]), abs(R[2, 1]), abs(R[0, 2]), abs(R[1, 2])))
        return tilt if tilt <= 1e-9 and R[2, 2] > 0 else None

    # -- the check -----------------------------------------------------
    def check(
        self,
        arm: str,
        qs: npt.ArrayLike,
        base: tuple[float, float, float] | npt.NDArray[np.float64],
        grasped: str | None = None,
        gone: Collection[str] = (),
        held: Held | None = None,
    ) -> CollisionResult:
        """Check the configurations ``qs`` (P, n) [rad/m] of ``arm`` with the base at ``base``
        (x [m], y [m], yaw [rad]); the gripper may touch the object named ``grasped``; the objects
        named in ``gone`` are not where the scene has them (already carried away) and are skipped;
        ``held`` (a :class:`~placement.collision.held.Held`): the object the gripper carries,
        checked along with the arm (see :mod:`placement.collision.held`)."""
        shapes = self.geometry.arm_shapes(arm)
        Q = np.atleast_2d(np.asarray(qs, dtype=float))
        n = self.robot.arm(arm).dof
        if Q.ndim != 2 or Q.shape[1] != n or not np.all(np.isfinite(Q)):
            raise PlacementError(
                f"collision check: qs must be (poses, {n}) finite joint values of arm '{arm}', got shape {Q.shape}"
            )
        for name in ([grasped] if grasped is not None else []) + list(gone):
            if name not in self.objects:
                raise PlacementError(
                    f"collision check: object '{name}' is not in the scene; objects: "
                    f"{', '.join(self.objects) or '(none)'}"
                )
        A = self.geometry.base_in_model @ np.linalg.inv(base_matrix(*(float(v) for v in base)))
        inst = self._instances(arm, Q, shapes)
        carried_at = None  # the held object's (P, 4, 4) world poses
        if held is not None:
            B = base_matrix(*(float(v) for v in base))
            carried_at = np.array([B @ self.robot.tcp_pose(arm, q) @ held.tcp_to_object for q in Q])
        Ainv = np.linalg.inv(A)
        grow = max(self.cap, self.padding)  # a piece pairs within the cap (or padding) of a bounding sphere
        box = influence_box(
            inst["centre"] @ Ainv[:3, :3].T + Ainv[:3, 3],
            inst["radius"] + grow,
            None if carried_at is None else carried_at[:, :3, 3],
            0.0 if held is None else 0.5 * float(np.linalg.norm(held.size)) + grow,
        )
        scene = self._scene_in_model(A, inst)
        pairs = self._pairs(inst, scene, shapes, grasped, frozenset(gone))
        # the collision tests of the pairs within the padding first: most placements a plan checks
        # collide (a forearm over a table's edge), and a hit needs no closest pair; a free one then
        # has its clearance from the closest pair (the same result in either order)
        hit = self._first_collision(pairs, inst, scene)
        if hit is not None:
            return replace(hit, box=box)
        free = self._closest(pairs, inst, scene)
        if held is not None:
            assert carried_at is not None
            carried = self._held(held, carried_at, A, inst, frozenset(gone) | {held.name})
            if not carried.free:
                return replace(carried, box=box)
            free = free if free.clearance_m <= carried.clearance_m else carried
        floor = floor_collision(inst, A, lambda k: self._robot(inst, k), self.geometry.names, held, carried_at)
        return replace(free if floor is None else floor, box=box)

    def gripper_collisions(
        self,
        arm: str,
        tcp_poses: Sequence[npt.ArrayLike],
        slack: float,
        grasped: str | None = None,
        gone: Collection[str] = (),
    ) -> list[CollisionResult | None]:
        """The gripper of ``arm`` alone at each trajectory's world TCP poses (each (P, 4, 4)) against the
        scene: per trajectory, the first of its shapes that comes more than ``slack`` [m] closer to a
        scene piece than the padding allows, as a collision (its ``clearance_m``: the padding less
        ``slack``, which the pair's distance is below), or None (for every trajectory when the gripper
        does not move rigidly with the TCP).

        The gripper's shapes (:class:`~placement.collision.robot.ArmShapes` ``gripper``, the fingers at
        the opening :meth:`check` holds them at) move with the TCP alone. So when one of them reaches
        ``slack`` past the padding into a piece here, :meth:`check` finds that arm in collision for every
        base pose and every configuration that puts each point of the gripper within ``slack`` of where it
        is here: a planner need not compute maps or IK for such a grasp (see
        :mod:`placement.planning.problems.screening`). Only box and cylinder pieces are tested when ``slack``
        exceeds the padding (they are shrunk by the difference: coal takes no negative margin against
        meshes). ``grasped`` and ``gone`` as in :meth:`check`."""
        rigid = self._gripper_frames(arm)
        trajectories = [np.asarray(T, dtype=float).reshape(-1, 4, 4) for T in tcp_poses]
        out: list[CollisionResult | None] = [None] * len(trajectories)
        if rigid is None or not trajectories:
            return out
        ids, rel = rigid
        T = np.concatenate(trajectories)
        owner = np.repeat(np.arange(len(trajectories)), [len(t) for t in trajectories])
        first = np.concatenate([[0], np.cumsum([len(t) for t in trajectories])[:-1]])
        A = self.geometry.base_in_model  # the base frame at the world's origin
        M = ((A @ T)[:, None] @ rel[None]).reshape(-1, 4, 4)
        geo = self.geometry
        inst_ids = np.tile(ids, len(T))
        R, t = M[:, :3, :3], M[:, :3, 3]
        inst: Instances = {
            "id": inst_ids,
            "pose": np.repeat(np.arange(len(T)), len(ids)),
            "poses": len(T),
            "R": R,
            "t": t,
            "centre": np.einsum("nij,nj->ni", R, geo.centre[inst_ids]) + t,
            "radius": geo.radius[inst_ids],
            "extent": np.einsum("nij,nj->ni", np.abs(R), geo.half[inst_ids]),
            "gripper": np.ones(len(inst_ids), dtype=bool),
            "tf": {},
        }
        shapes = ArmShapes(ids, ids, np.zeros(0, dtype=int), np.zeros((0, 2), dtype=int))
        scene = self._scene_in_model(A, inst)
        pairs = self._pairs(inst, scene, shapes, grasped, frozenset(gone))
        # closer than padding - slack: a margin when that is >= 0; else a point of the gripper lies
        # deeper than slack - padding inside the piece, i.e. inside the piece shrunk by that much
        margin = self.padding - max(float(slack), 0.0)
        depth = max(-margin, 0.0)
        req = coal.CollisionRequest()
        req.security_margin = max(margin, 0.0)
        near = np.flatnonzero(pairs["lb"] <= max(margin, 0.0))
        pieces: dict[int, tuple[coal.CollisionGeometry, coal.Transform3s] | None] = {}
        for k in near[np.lexsort((pairs["lb"][near], inst["pose"][pairs["a"][near]]))]:
            a, b = int(pairs["a"][k]), int(pairs["b"][k])
            c = int(owner[inst["pose"][a]])
            if out[c] is not None:
                continue
            if b not in pieces:
                piece = eroded(self._piece(scene, b), depth)
                Tp = A @ piece.pose if piece is not None else None
                pieces[b] = (
                    None if piece is None or Tp is None else (piece.geometry, coal.Transform3s(Tp[:3, :3], Tp[:3, 3]))
                )
            hit = pieces[b]
            if hit is None:
                continue
            g2, T2 = hit
            g1, hull, exact, T1 = self._robot(inst, a)
            if self._collide(hull, T1, g2, T2, req) and (exact or self._collide(g1, T1, g2, T2, req)):
                name, pose = self._name(pairs, k, inst, scene)
                assert pose is not None  # every instance here moves with its trajectory
                out[c] = CollisionResult(False, margin, name, pose - int(first[c]))
        return out

    def gripper_twin(self, arm: str) -> str | None:
        """The first arm (in the robot's order, before ``arm``) whose gripper is ``arm``'s over again, or
        None: the same shapes (kind, mesh and scale, bounds), in the same order, at the same poses in the
        TCP frame (within :data:`TWIN_TOL_M` [m], far below any screen's slack). :meth:`gripper_collisions`
        then answers both alike, but for the culprit's link (:meth:`twin_results`): a two-armed robot's
        screen is made once for both hands."""
        if arm in self._twins:
            return self._twins[arm]
        mine = self._gripper_frames(arm)
        found = None
        for other in self.robot.arms:
            if other == arm:
                break
            theirs = self._gripper_frames(other)
            if mine is None or theirs is None or len(mine[0]) != len(theirs[0]):
                continue
            if self._shape_keys(mine[0]) == self._shape_keys(theirs[0]) and np.allclose(
                mine[1], theirs[1], rtol=0.0, atol=TWIN_TOL_M
            ):
                found = other
                break
        self._twins[arm] = found
        return found

    def _shape_keys(self, ids: npt.NDArray[np.int_]) -> list[tuple[object, ...]]:
        """What makes robot shapes ``ids`` the shapes they are: kind, mesh file, vertex and triangle
        counts, and the local bounds and mesh scale (to :data:`TWIN_TOL_M`)."""
        geo = self.geometry
        out: list[tuple[object, ...]] = []
        for g in ids:
            o = geo.geom.geometryObjects[int(g)]
            counts = [getattr(o.geometry, attr, None) for attr in ("num_vertices", "num_tris")]
            bounds = np.concatenate([geo.centre[g], geo.half[g], [geo.radius[g]], np.asarray(o.meshScale)])
            out.append(
                (
                    type(o.geometry).__name__,
                    str(o.meshPath),
                    tuple(c() if callable(c) else c for c in counts),
                    bool(geo.exact[g]),
                    tuple(int(v) for v in np.round(bounds / TWIN_TOL_M)),
                )
            )
        return out

    def twin_results(self, hits: Sequence[CollisionResult | None], twin: str, arm: str) -> list[CollisionResult | None]:
        """:meth:`gripper_collisions` of ``arm`` from those of its :meth:`gripper_twin` ``twin``: the same,
        each culprit named by ``arm``'s link."""
        ours, theirs = self._gripper_frames(arm), self._gripper_frames(twin)
        assert ours is not None and theirs is not None
        names = self.geometry.names
        link = {names[int(t)]: names[int(o)] for t, o in zip(theirs[0], ours[0])}
        out: list[CollisionResult | None] = []
        for h in hits:
            if h is None or h.culprit is None:
                out.append(h)
                continue
            part, _, piece = h.culprit.partition(" vs ")
            out.append(replace(h, culprit=f"{link.get(part, part)} vs {piece}"))
        return out

    def gripper_reach(self, arm: str) -> float:
        """How far [m] the gripper of ``arm`` reaches from its TCP: the largest distance from the TCP to a
        point of its shapes' bounding spheres (0 when it does not move rigidly with the TCP). A turn of the
        TCP by a small angle [rad] moves no point of the gripper by more than this times the angle."""
        rigid = self._gripper_frames(arm)
        if rigid is None:
            return 0.0
        ids, rel = rigid
        geo = self.geometry
        centres = np.einsum("gij,gj->gi", rel[:, :3, :3], geo.centre[ids]) + rel[:, :3, 3]
        return float((np.linalg.norm(centres, axis=1) + geo.radius[ids]).max(initial=0.0))

    def _gripper_frames(self, arm: str) -> tuple[npt.NDArray[np.int_], npt.NDArray[np.float64]] | None:
        """(shape ids (G,), their poses in the TCP frame (G, 4, 4)) of ``arm``'s gripper, or None when it
        has no shapes or the TCP is not moved by the arm's last joint (the gripper is then not rigid with it)."""
        if arm in self._grippers:
            return self._grippers[arm]
        robot, geo = self.robot, self.geometry
        a = robot.arm(arm)
        model = robot.model
        after_last = moved_joints(model, [a.joint_ids[-1]])
        tip_joint = model.frames[frame_id(model, a.tip_frame)].parentJoint
        ids = np.asarray(geo.arm_shapes(arm).gripper, dtype=int)
        out = None
        if len(ids) and tip_joint in after_last and all(int(geo.joint[g]) in after_last for g in ids):
            assert a.idle is not None  # (never None: Arm.__post_init__)
            tcp = robot.tcp_pose(arm, a.idle)  # in the base frame, the arm idle as in home_placements
            to_tcp = np.linalg.inv(tcp) @ np.linalg.inv(geo.base_in_model)
            out = ids, np.array([to_tcp @ geo.home_placements[int(g)].homogeneous for g in ids])
        self._grippers[arm] = out
        return out

    def _held(
        self,
        held: Held,
        world: npt.NDArray[np.float64],
        A: npt.NDArray[np.float64],
        inst: Instances,
        skip: frozenset[str],
    ) -> CollisionResult:
        """The held object at its world poses ``world`` (P, 4, 4) along the trajectory against the
        scene and the robot (see held.py)."""
        check = HeldCheck(held, world, self.padding, self.cap)
        reach = check.radius + max(self.cap, self.padding)
        lo, hi = world[:, :3, 3].min(axis=0) - reach, world[:, :3, 3].max(axis=0) + reach
        pieces = list(self.shapes) if self._grid is None else [self.shapes[i] for i in self._grid.near(lo, hi)]
        if self.cells is not None:
            rows, cols = self.cells.near(lo[0], lo[1], hi[0], hi[1])
            pieces += [self.cells.shape(int(r), int(c)) for r, c in zip(rows, cols)]
        hit, clearance = check.scene(pieces, set(skip))
        name = f"{held.name} (held)"
        if hit is not None:
            return CollisionResult(False, hit[0], f"{name} vs {hit[1]}", hit[2])
        robot_hit = check.robot(A, inst, lambda k: self._robot(inst, k))
        if robot_hit is not None:
            d, k, pose = robot_hit
            return CollisionResult(False, d, f"{name} vs {self.geometry.names[int(inst['id'][k])]}", pose)
        return CollisionResult(True, clearance, None if clearance >= self.cap else name, None)

    def _instances(self, arm: str, qs: npt.NDArray[np.float64], shapes: ArmShapes) -> Instances:
        """Robot shapes to test, in the model frame: the static ones once, the moving ones per pose."""
        model, geo = self.robot.model, self.geometry
        id_parts = [shapes.static]
        poses = [np.full(len(shapes.static), -1)]
        R_parts, t_parts = [self._home_R[shapes.static]], [self._home_t[shapes.static]]
        for p, q in enumerate(qs):
            pin.updateGeometryPlacements(
                model, self._data, geo.geom, self._gdata, self.robot.full_q(arm, q, geo.home_q)
            )
            Ms = [self._gdata.oMg[int(g)] for g in shapes.moving]
            id_parts.append(shapes.moving)
            poses.append(np.full(len(shapes.moving), p))
            R_parts.append(np.array([M.rotation for M in Ms]).reshape(-1, 3, 3))
            t_parts.append(np.array([M.translation for M in Ms]).reshape(-1, 3))
        ids, R, t = np.concatenate(id_parts).astype(int), np.concatenate(R_parts), np.concatenate(t_parts)
        centre = np.einsum("nij,nj->ni", R, geo.centre[ids]) + t
        gripper = np.isin(ids, shapes.gripper)
        return {
            "id": ids,
            "pose": np.concatenate(poses),
            "poses": len(qs),
            "R": R,
            "t": t,
            "centre": centre,
            "radius": geo.radius[ids],
            "extent": np.einsum("nij,nj->ni", np.abs(R), geo.half[ids]),
            "gripper": gripper,
            "tf": {},
        }

    def _scene_in_model(self, A: npt.NDArray[np.float64], inst: Instances) -> ScenePieces:
        """Scene pieces near the robot in the model frame: the shapes (those the grid finds in reach,
        in scene order) and the occupancy cells in reach; ``objects``: the object of each piece or None."""
        shapes: Sequence[SceneShape | tuple[int, int]] = self.shapes
        aabb, objects = self._aabb, self._object_of
        if (self.cells is not None or self._grid is not None) and len(inst["id"]):
            reach = inst["radius"].max() + self.cap + self.padding
            Ainv = np.linalg.inv(A)
            world = inst["centre"] @ Ainv[:3, :3].T + Ainv[:3, 3]
            lo, hi = world.min(axis=0) - reach, world.max(axis=0) + reach
            if self._grid is not None:  # a piece beyond every instance's radius + cap has no pair
                r = inst["radius"][:, None] + (self.cap + self.padding + GRID_SLACK)
                near = self._grid.near((world[:, :2] - r).min(axis=0), (world[:, :2] + r).max(axis=0))
                shapes, aabb, objects = [shapes[i] for i in near], aabb[near], [objects[i] for i in near]
            if self.cells is not None:
                rows, cols = self.cells.near(lo[0], lo[1], hi[0], hi[1])
                if len(rows):
                    c = self.cells.centres(rows, cols)
                    half = np.array([self.cells.resolution / 2, self.cells.resolution / 2, self.cells.height / 2])
                    aabb = np.concatenate([aabb, np.stack([c - half, c + half], axis=1)])
                    shapes = [*shapes, *((int(r), int(k)) for r, k in zip(rows, cols))]  # made into pieces when needed
                    objects = objects + [None] * len(rows)
        elif self._grid is not None:  # no robot shapes: nothing can pair
            shapes, aabb, objects = [], aabb[:0], []
        return {
            "shapes": list(shapes),
            "aabb": model_aabb(aabb, A) if len(aabb) else aabb,
            "A": A,
            "tf": {},
            "objects": objects,
        }

    def _pairs(
        self, inst: Instances, scene: ScenePieces, shapes: ArmShapes, grasped: str | None, gone: frozenset[str]
    ) -> Pairs:
        """Candidate pairs with a lower bound of their distance [m]: robot-scene then self."""
        return candidate_pairs(inst, scene, shapes, self.geometry.geom.ngeoms, self.cap, grasped, gone)

    # -- narrow phase --------------------------------------------------
    def _robot(self, inst: Instances, k: int) -> Operand:
        """(shape, its convex hull, hull is the shape, coal transform) of robot instance ``k``."""
        hit = inst["tf"].get(k)
        if hit is None:
            g = int(inst["id"][k])
            geo = self.geometry
            hit = inst["tf"][k] = (
                geo.geom.geometryObjects[g].geometry,
                geo.hulls[g],
                bool(geo.exact[g]),
                coal.Transform3s(inst["R"][k], inst["t"][k]),
            )
        return hit

    def _piece(self, scene: ScenePieces, s: int) -> SceneShape:
        """Scene piece ``s``, an occupancy cell made into its shape on first use."""
        piece = scene["shapes"][s]
        if isinstance(piece, tuple):
            assert self.cells is not None  # cells enter the pieces only from the occupancy map
            piece = scene["shapes"][s] = self.cells.shape(*piece)
        return piece

    def _scene(self, scene: ScenePieces, s: int) -> Operand:
        hit = scene["tf"].get(s)
        if hit is None:
            piece = self._piece(scene, s)
            T = scene["A"] @ piece.pose
            hit = scene["tf"][s] = (piece.geometry, piece.geometry, True, coal.Transform3s(T[:3, :3], T[:3, 3]))
        return hit

    def _operands(self, pairs: Pairs, k: int, inst: Instances, scene: ScenePieces) -> tuple[Operand, Operand]:
        a, b = int(pairs["a"][k]), int(pairs["b"][k])
        return self._robot(inst, a), (self._robot(inst, b) if pairs["self"][k] else self._scene(scene, b))

    def _name(self, pairs: Pairs, k: int, inst: Instances, scene: ScenePieces) -> tuple[str, int | None]:
        a, b = int(pairs["a"][k]), int(pairs["b"][k])
        names = self.geometry.names
        other = names[int(inst["id"][b])] if pairs["self"][k] else self._piece(scene, b).name
        p = max(int(inst["pose"][a]), int(inst["pose"][b]) if pairs["self"][k] else -1)
        return f"{names[int(inst['id'][a])]} vs {other}", (None if p < 0 else p)

    def _distance(
        self, g1: coal.CollisionGeometry, T1: coal.Transform3s, g2: coal.CollisionGeometry, T2: coal.Transform3s
    ) -> float:
        self._dres.clear()
        return float(coal.distance(g1, T1, g2, T2, self._dreq, self._dres))

    def _collide(
        self,
        g1: coal.CollisionGeometry,
        T1: coal.Transform3s,
        g2: coal.CollisionGeometry,
        T2: coal.Transform3s,
        req: coal.CollisionRequest,
    ) -> bool:
        self._cres.clear()
        return bool(coal.collide(g1, T1, g2, T2, req, self._cres))

    def _first_collision(self, pairs: Pairs, inst: Instances, scene: ScenePieces) -> CollisionResult | None:
        margin = np.where(pairs["self"], 0.0, self.padding)
        near = np.flatnonzero(pairs["lb"] <= margin)
        for k in near[np.argsort(pairs["lb"][near], kind="stable")]:
            (g1, h1, e1, T1), (g2, h2, e2, T2) = self._operands(pairs, k, inst, scene)
            req = self._self_req if pairs["self"][k] else self._scene_req
            # hulls apart means the shapes are apart
            if not self._collide(h1, T1, h2, T2, req) or not (e1 and e2 or self._collide(g1, T1, g2, T2, req)):
                continue
            name, pose = self._name(pairs, k, inst, scene)
            return CollisionResult(False, self._distance(g1, T1, g2, T2), name, pose)
        return None

    def _closest(self, pairs: Pairs, inst: Instances, scene: ScenePieces) -> CollisionResult:
        """The pair at the smallest distance below the cap, best first: each pair's key is a lower bound
        of its distance (bounding volumes, then its convex hulls' distance, then the exact distance); the
        pair with the smallest key is refined until an exact distance comes first: no other pair can be
        nearer. Coal's GJK tolerance is far below HULL_SLACK, so hull keys are lowered by it."""
        order = np.argsort(pairs["lb"], kind="stable")
        # plain lists and local names: this loop runs for every pair below the best distance
        lbs, ks = pairs["lb"][order].tolist(), order.tolist()
        a_of, b_of, is_self = pairs["a"].tolist(), pairs["b"].tolist(), pairs["self"].tolist()
        robot, piece, distance, push, pop = self._robot, self._scene, self._distance, heapq.heappush, heapq.heappop
        cap, n = self.cap, len(ks)
        heap: list[tuple[float, int, int]] = []  # (key, stage 1 hull / 2 exact, pair)
        nxt = 0
        while True:
            top = heap[0][0] if heap else math.inf
            if nxt < n and lbs[nxt] < min(top, cap):
                k = ks[nxt]
                nxt += 1
                _, h1, e1, T1 = robot(inst, a_of[k])
                _, h2, e2, T2 = robot(inst, b_of[k]) if is_self[k] else piece(scene, b_of[k])
                d = distance(h1, T1, h2, T2)
                push(heap, (d, 2, k) if e1 and e2 else (d - HULL_SLACK, 1, k))
                continue
            if not heap or top >= cap:
                return CollisionResult(True, self.cap, None, None)
            key, stage, k = pop(heap)
            if stage == 2:
                name, pose = self._name(pairs, k, inst, scene)
                return CollisionResult(True, key, name, pose)
            g1, _, _, T1 = robot(inst, a_of[k])
            g2, _, _, T2 = robot(inst, b_of[k]) if is_self[k] else piece(scene, b_of[k])
            push(heap, (distance(g1, T1, g2, T2), 2, k))
