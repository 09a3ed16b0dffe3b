"""The serial chain of one arm, extracted from a pinocchio model as plain arrays.

The numba kernels never see pinocchio: they get, per arm joint, the fixed
transform from the previous joint frame (everything in between, including
joints the preset holds fixed, folded in), the joint axis in its own frame and
whether it turns or slides.  FK is then ``base_T @ prod(link_T[i] @ motion_i(q_i)) @ tip_T``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from placement.errors import RobotError

REVOLUTE = 0
PRISMATIC = 1


@dataclass(frozen=True)
class Chain:
    """Kernel-ready description of one arm chain (base frame -> canonical TCP).

    Attributes:
        link_T: (n, 4, 4) transform from the previous joint frame (the base frame
            for joint 0) to joint i's frame with q_i = 0, in metres.
        axis: (n, 3) unit joint axis in joint i's frame.
        kind: (n,) int64, 0 = revolute (incl. continuous), 1 = prismatic.
        tip_T: (4, 4) from the last joint frame to the canonical TCP frame.
    """

    link_T: np.ndarray
    axis: np.ndarray
    kind: np.ndarray
    tip_T: np.ndarray

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(link_T, axis, kind, tip_T)``: the chain as every chain kernel takes it, in that order
        (``kernel(q, *chain.arrays, ...)``), so that no caller spells the argument list out."""
        return self.link_T, self.axis, self.kind, self.tip_T


def ancestors(model: pin.Model, joint_id: int) -> list[int]:
    """Joint ids from ``joint_id`` up to (excluding) the universe, nearest first."""
    out = []
    while joint_id > 0:
        out.append(joint_id)
        joint_id = model.parents[joint_id]
    return out


def extract_chain(
    model: pin.Model,
    q0: np.ndarray,
    base_frame_id: int,
    joint_ids: list[int],
    tip_frame_id: int,
    tcp_offset: np.ndarray,
    names: tuple[str, str],
    data: pin.Data | None = None,
) -> Chain:
    """Build a :class:`Chain` from ``model`` at the reference configuration ``q0``.

    ``q0`` must hold the arm joints at zero motion; joints between the arm joints
    that are not arm joints keep their ``q0`` value (the preset's fixed joints).
    ``names`` is (robot name, arm name) for error messages. ``data``: a
    ``model.createData()`` to reuse (creating one costs milliseconds on a large model).
    """
    robot, arm = names
    tip_chain = ancestors(model, model.frames[tip_frame_id].parentJoint)
    previous = None
    for jid in joint_ids:
        if jid not in tip_chain:
            raise RobotError(
                f"arm '{arm}' of robot '{robot}': joint '{model.names[jid]}' does not move "
                f"the tip frame '{model.frames[tip_frame_id].name}'"
            )
        if previous is not None and previous not in ancestors(model, jid)[1:]:
            raise RobotError(
                f"arm '{arm}' of robot '{robot}': joints must be listed from the base to the tip; "
                f"'{model.names[jid]}' comes before '{model.names[previous]}'"
            )
        previous = jid
    base_chain = ancestors(model, model.frames[base_frame_id].parentJoint)
    moving = set(joint_ids) & set(base_chain)
    if moving:
        raise RobotError(
            f"arm '{arm}' of robot '{robot}': the base frame '{model.frames[base_frame_id].name}' "
            f"moves with arm joint '{model.names[min(moving)]}'"
        )

    data = model.createData() if data is None else data
    pin.forwardKinematics(model, data, q0)
    pin.updateFramePlacements(model, data)
    pin.computeJointJacobians(model, data, q0)
    n = len(joint_ids)
    link_T = np.zeros((n, 4, 4))
    axis = np.zeros((n, 3))
    kind = np.zeros(n, dtype=np.int64)
    prev_M = data.oMf[base_frame_id]
    for i, jid in enumerate(joint_ids):
        jm = model.joints[jid]
        if jm.nv != 1:
            raise RobotError(
                f"arm '{arm}' of robot '{robot}': joint '{model.names[jid]}' has {jm.nv} degrees "
                "of freedom; only revolute, continuous and prismatic joints can be arm joints"
            )
        link_T[i] = (prev_M.inverse() * data.oMi[jid]).homogeneous
        motion = pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, jm.idx_v]
        lin, ang = motion[:3], motion[3:]
        if not (np.linalg.norm(ang) > 0.5 or np.linalg.norm(lin) > 0.5):  # a zero (or NaN) axis in the URDF
            raise RobotError(
                f"arm '{arm}' of robot '{robot}': joint '{model.names[jid]}' has no usable axis in the URDF "
                f"(<axis xyz> of length {float(np.linalg.norm(ang) + np.linalg.norm(lin)):.3g}, not 1)"
            )
        if np.linalg.norm(ang) > 0.5:
            axis[i] = ang / np.linalg.norm(ang)
            kind[i] = REVOLUTE
        else:
            axis[i] = lin / np.linalg.norm(lin)
            kind[i] = PRISMATIC
        prev_M = data.oMi[jid]
    tip_T = (prev_M.inverse() * data.oMf[tip_frame_id]).homogeneous @ tcp_offset
    return Chain(link_T=link_T, axis=axis, kind=kind, tip_T=tip_T)
