"""The robot drawn from its URDF's visual meshes (pinocchio's geometry model) at a base pose and a
configuration. Node names start with the drawing's root (``/robot``)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from placement.errors import RobotError
from placement.planning.verification import pinocchio_q, resting
from placement.robots.description import package_dirs, read_description, readable_urdf
from placement.viewer.geometry import pose_matrix

if TYPE_CHECKING:
    from collections.abc import Callable

    import viser

    from placement.planning.results import PlacedStep
    from placement.robots import Robot

log = logging.getLogger("placement")

ROBOT = (70, 130, 225)  # one colour for every part: the robot stands out from the scene's greys and browns


def geometry_mesh(obj: pin.GeometryObject) -> tuple[npt.NDArray[np.float32], npt.NDArray[np.int32]] | None:
    """(vertices (n, 3), faces (m, 3)) of one pinocchio GeometryObject in its own frame [m], or None
    for a shape the viewer does not draw."""
    import coal
    import trimesh

    g = obj.geometry
    if isinstance(g, coal.Box):
        m = trimesh.creation.box(extents=2.0 * np.asarray(g.halfSide))
    elif isinstance(g, coal.Sphere):
        m = trimesh.creation.icosphere(subdivisions=2, radius=g.radius)
    elif isinstance(g, coal.Cylinder):
        m = trimesh.creation.cylinder(radius=g.radius, height=2.0 * g.halfLength, sections=24)
    elif obj.meshPath and Path(obj.meshPath).is_file():
        m = trimesh.load(obj.meshPath, force="mesh")
        # (trimesh leaves apply_scale unannotated)
        cast("Callable[[npt.ArrayLike], object]", m.apply_scale)(np.asarray(obj.meshScale))
    else:
        return None
    return np.asarray(m.vertices, dtype=np.float32), np.asarray(m.faces, dtype=np.int32)


def wxyz(R: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Quaternion (w, x, y, z) of a rotation matrix."""
    x, y, z, w = pin.Quaternion(np.asarray(R, dtype=float)).coeffs()
    return np.array([w, x, y, z])


class RobotDrawing:
    """A robot in a viser scene under the node ``root``; :meth:`show` places it.

    The meshes are sent once; a new pose or configuration only moves nodes. A URDF whose meshes
    cannot be loaded is drawn as a stick figure of its joints instead (with a warning).
    """

    def __init__(
        self, server: viser.ViserServer, robot: Robot, root: str = "/robot", color: tuple[int, int, int] = ROBOT
    ) -> None:
        self.server, self.robot, self.root = server, robot, root
        self.data = robot.model.createData()
        self.frame = server.scene.add_frame(root, show_axes=False)
        self.nodes: list[tuple[int, viser.MeshHandle]] = []
        self.geom = None
        try:
            text, _ = readable_urdf(read_description(robot.urdf_path, str(robot.urdf_path)).decode("utf-8", "replace"))
            self.geom = pin.buildGeomFromUrdfString(
                robot.model, text, pin.GeometryType.VISUAL, package_dirs=package_dirs(robot.urdf_path)
            )
        except (ValueError, RuntimeError, RobotError) as exc:
            log.warning(
                "robot %s: visual meshes not loaded (%s); drawing its joints only",
                robot.name,
                " ".join(str(exc).split())[:120],
            )
        if self.geom is not None:
            self.geom_data = pin.GeometryData(self.geom)
            for i, obj in enumerate(self.geom.geometryObjects):
                mesh = geometry_mesh(obj)
                if mesh is not None:
                    self.nodes.append(
                        (
                            i,
                            server.scene.add_mesh_simple(
                                f"{root}/{i:03d}_{obj.name}", *mesh, color=color, flat_shading=False
                            ),
                        )
                    )
        self.sticks = (
            None
            if self.nodes
            else server.scene.add_line_segments(
                f"{root}/joints", np.zeros((1, 2, 3), np.float32), color, thickness=0.03
            )
        )

    @property
    def visible(self) -> bool:
        return self.frame.visible

    @visible.setter
    def visible(self, value: bool) -> None:
        self.frame.visible = bool(value)

    def show(self, base: tuple[float, float, float], q: npt.NDArray[np.float64]) -> None:
        """Draw the robot with its base frame at ``base`` (x [m], y [m], yaw [rad]) on the floor, in the
        pinocchio configuration ``q`` (model.nq,)."""
        model = self.robot.model
        pin.forwardKinematics(model, self.data, q)
        B = pin.updateFramePlacement(model, self.data, self.robot.base_frame_id).homogeneous
        # the model's root is wherever the URDF puts it; this places the base frame at the base pose
        root = pose_matrix(*base) @ np.linalg.inv(B)
        with self.server.atomic():
            self.frame.position = root[:3, 3]
            self.frame.wxyz = wxyz(root[:3, :3])
            if self.nodes:
                pin.updateGeometryPlacements(model, self.data, self.geom, self.geom_data)
                for i, node in self.nodes:
                    M = self.geom_data.oMg[i]
                    node.position = M.translation
                    node.wxyz = wxyz(M.rotation)
            else:
                p = np.array([self.data.oMi[j].translation for j in range(model.njoints)])
                parents = list(model.parents)
                assert self.sticks is not None  # drawn when no mesh node is
                self.sticks.points = np.stack([p[parents[1:]], p[1:]], axis=1).astype(np.float32)
            self.frame.visible = True


def step_config(robot: Robot, step: PlacedStep) -> npt.NDArray[np.float64]:
    """Pinocchio configuration (model.nq,) of a planned ``step`` at its last TCP pose: its whole
    configuration (:meth:`~placement.planning.StepResult.whole_joints`), so the arm at its IK
    solution, the fixed joints at the step's values (a torso raised for this step is drawn raised),
    the other arms idle and the rest neutral; a step without :attr:`resting` gets the planner's."""
    r = step.resting if step.resting is not None else resting(robot, step.arm)
    joints = step.whole_joints(r) | dict(zip(robot.arm(step.arm).joints, map(float, step.q)))
    return pinocchio_q(robot, joints)


def config_of(robot: Robot, arm: str, q: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Pinocchio configuration with ``q`` on ``arm``, every other arm at its idle pose (where the
    collision check and the plan's ``configuration`` put it) and the preset's fixed joints set (a
    planned step's robot is drawn at :func:`step_config`, with the step's fixed-joint values)."""
    ref = None
    for other in robot.arms:
        if other != arm:
            idle = robot.arm(other).idle
            ref = robot.full_q(other, robot.arm(other).home if idle is None else idle, reference=ref)
    return robot.full_q(arm, q, reference=ref)


def home_config(robot: Robot) -> npt.NDArray[np.float64]:
    """Pinocchio configuration with every arm at its home pose."""
    q = None
    for arm in robot.arms:
        q = robot.full_q(arm, robot.arm(arm).home, reference=q)
    assert q is not None  # a robot has an arm
    return q
