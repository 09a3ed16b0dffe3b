"""PNGs of ``placement robots check --plot DIR``: a side view of the robot with its reach bands, and a
close-up of each gripper with its TCP frame (x red, y green, z = approach blue), so that a wrong
approach axis is seen at once."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from placement.robots.chain import ancestors

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from placement.robots.preset import Robot


#: Length of the drawn TCP axes [m].
AXIS = 0.08
COLORS = {"down": "tab:blue", "horizontal": "tab:orange"}


def home_q(robot: Robot) -> np.ndarray:
    """Pinocchio configuration with every arm at its home and the fixed joints held."""
    q = robot.reference_q()
    for arm in robot.arms:
        q = robot.full_q(arm, robot.arm(arm).home, q)
    return q


def joint_points(robot: Robot, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """((njoints, 3) joint origins and (m, 3) body frame origins [m] in the base frame at ``q``;
    index 0 is the universe)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    base = data.oMf[robot.base_frame_id].inverse()
    joints = np.array([(base * data.oMi[j]).translation for j in range(robot.model.njoints)])
    bodies = np.array(
        [(base * data.oMf[i]).translation for i, f in enumerate(robot.model.frames) if f.type == pin.FrameType.BODY]
    )
    return joints, bodies


def draw_links(ax: Axes, robot: Robot, joints: np.ndarray, dims: tuple[int, int] = (0, 2), **kw: Any) -> None:
    """Segments parent joint -> joint (the kinematic skeleton) projected on ``dims``."""
    for j in range(1, robot.model.njoints):
        p = robot.model.parents[j]
        a, b = joints[p], joints[j]
        ax.plot([a[dims[0]], b[dims[0]]], [a[dims[1]], b[dims[1]]], color=kw.get("color", "0.3"), lw=kw.get("lw", 1.5))


def plot_side(robot: Robot, doc: dict[str, Any], path: Path) -> Path:
    """Side view (x forward, z up, base frame) with the robot at home and each arm's reach profiles."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from placement.robots.onboarding.check import TABLE_HEIGHT

    joints, bodies = joint_points(robot, home_q(robot))
    fig, ax = plt.subplots(figsize=(7, 6))
    for approach, color in COLORS.items():
        first = True
        for v in doc["arms"].values():
            for s in v["bands"][approach]["profile"]:
                ax.fill_between(
                    [s["r_min"], s["r_max"]],
                    s["z"][0],
                    s["z"][1],
                    color=color,
                    alpha=0.12,
                    lw=0,
                    label=f"{approach} TCP reach (distance from the base axis)" if first else None,
                )
                first = False
    ax.scatter(bodies[:, 0], bodies[:, 2], s=4, color="0.5", label="link frames (home)")
    draw_links(ax, robot, joints)
    for arm in robot.arms:
        T = robot.tcp_pose(arm, robot.arm(arm).home)
        ax.quiver(T[0, 3], T[2, 3], T[0, 2], T[2, 2], color="b", scale=12, width=0.005)
    ax.axhline(TABLE_HEIGHT, color="tab:brown", ls="--", lw=1, label=f"table {TABLE_HEIGHT} m")
    ax.axhline(0, color="k", lw=1)
    ax.set_aspect("equal")
    ax.set_xlabel("x forward / distance from the base axis [m]")
    ax.set_ylabel("z above the floor [m]")
    ax.set_title(f"{robot.name}: reach bands ({', '.join(f'{k}={v:g}' for k, v in robot.fixed_joints.items())})")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_tcp(robot: Robot, arm: str, path: Path) -> Path:
    """3D close-up of ``arm``'s hand at home: the hand's skeleton, its link frames and the TCP axes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a = robot.arm(arm)
    joints, _ = joint_points(robot, home_q(robot))
    T = robot.tcp_pose(arm, a.home)
    last = a.joint_ids[-1]
    hand = [j for j in range(1, robot.model.njoints) if last in ancestors(robot.model, j)]
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="3d")
    for j in hand:
        p = robot.model.parents[j]
        ax.plot(*zip(joints[p], joints[j]), color="0.4")
    wrist = joints[last]
    ax.plot(*zip(joints[robot.model.parents[last]], wrist), color="0.2", lw=3)
    for k, color in enumerate("rgb"):
        ax.quiver(*T[:3, 3], *(AXIS * T[:3, k]), color=color, lw=2)
    ax.text(*(T[:3, 3] + AXIS * 1.1 * T[:3, 2]), "approach z", color="b", fontsize=8)
    c = T[:3, 3]
    lim = max(0.12, float(np.linalg.norm(c - wrist)) * 1.3)
    for setter, v in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), c):
        setter(v - lim, v + lim)
    ax.set_title(
        f"{robot.name} arm {arm}: TCP on {a.tip_frame}\n(x red, y green = closing, z blue = approach)", fontsize=9
    )
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def plot_check(robot: Robot, doc: dict[str, Any], out_dir: Path) -> list[str]:
    """Write ``<robot>_reach.png`` and ``<robot>_tcp_<arm>.png`` into ``out_dir``; their paths."""
    out_dir = Path(out_dir)
    paths = [plot_side(robot, doc, out_dir / f"{robot.name}_reach.png")]
    paths += [plot_tcp(robot, arm, out_dir / f"{robot.name}_tcp_{arm}.png") for arm in robot.arms]
    return [str(p) for p in paths]
