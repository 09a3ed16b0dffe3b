"""A small robot whose arm spans 5 dimensions of the 6: a box base, a prismatic lift (z), four
prismatic telescoping joints along x and a 3-joint wrist (yaw, pitch, roll) with a tip frame.

Its 6 x 8 TCP Jacobian has rank 5 at every configuration (no motion along the base's y but through
the wrist, which the wrist's rotations already use up), the arm reaches about 1.5 m forward of the
base centre, and the sum of its link lengths and strokes is about 2.6 m: what the map tests of
rank-deficient arms and of grid sizing need. Written here for tests; not a model of a real robot.
"""

from __future__ import annotations

from pathlib import Path

import yaml

import placement

#: Arm joints in chain order.
JOINTS = ("lift", "tele_1", "tele_2", "tele_3", "tele_4", "wrist_yaw", "wrist_pitch", "wrist_roll")
#: Stroke of each telescoping joint [m], and of the lift [m] (from LIFT_LOW).
TELE_STROKE = 0.25
LIFT_LOW, LIFT_HIGH = 0.2, 1.1
#: Rough forward reach of the TCP from the base centre [m] (all joints extended, wrist straight).
REACH_X = 0.1 + 0.2 + 4 * TELE_STROKE + 0.1 + 0.05 + 0.05 + 0.1


def _link(name: str, box: str | None = None) -> str:
    if box is None:
        return f'<link name="{name}"/>'
    return f'<link name="{name}"><collision><geometry><box size="{box}"/></geometry></collision></link>'


def _joint(name: str, kind: str, parent: str, child: str, xyz: str, axis: str, lo: float, hi: float) -> str:
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        f'<limit lower="{lo}" upper="{hi}" effort="10" velocity="0.5"/></joint>'
    )


def telescoping_urdf(name: str = "telescoping") -> str:
    """URDF text of the robot (see the module docstring); lengths in metres, angles in radians."""
    parts = [
        f'<robot name="{name}">',
        _link("base_footprint"),
        _link("base_link", "0.4 0.4 0.3"),
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
        '<origin xyz="0 0 0.15"/></joint>',
        _link("mast"),
        _joint("lift", "prismatic", "base_link", "mast", "0.1 0 0", "0 0 1", LIFT_LOW, LIFT_HIGH),
    ]
    parent = "mast"
    for i in range(1, 5):
        parts.append(_link(f"tele_link_{i}"))
        xyz = "0.2 0 0" if i == 1 else "0 0 0"
        parts.append(_joint(f"tele_{i}", "prismatic", parent, f"tele_link_{i}", xyz, "1 0 0", 0.0, TELE_STROKE))
        parent = f"tele_link_{i}"
    wrist = (
        ("wrist_yaw", "0.1 0 0", "0 0 1", -2.5, 2.5),
        ("wrist_pitch", "0.05 0 0", "0 1 0", -1.5, 1.0),
        ("wrist_roll", "0.05 0 0", "1 0 0", -3.0, 3.0),
    )
    for joint, xyz, axis, lo, hi in wrist:
        parts.append(_link(f"{joint}_link"))
        parts.append(_joint(joint, "revolute", parent, f"{joint}_link", xyz, axis, lo, hi))
        parent = f"{joint}_link"
    parts += [
        _link("tool_frame"),
        f'<joint name="tool_joint" type="fixed"><parent link="{parent}"/><child link="tool_frame"/>'
        '<origin xyz="0.1 0 0"/></joint>',
        "</robot>",
    ]
    return "\n".join(parts)


def telescoping_preset(urdf: str) -> dict:
    """The preset mapping for the URDF file ``urdf``: one arm ``arm``, TCP z along the tool's x."""
    return {
        "name": "telescoping",
        "urdf": urdf,
        "base_frame": "base_footprint",
        "footprint_radius": 0.3,
        "v_max": 0.3,
        "omega_max": 1.0,
        "arms": {
            "arm": {
                "joints": list(JOINTS),
                "tip_frame": "tool_frame",
                "tcp_offset": [0.0, 0.0, 0.0, 0.0, 0.7071067811865476, 0.0, 0.7071067811865476],
                "home": [0.6, 0.1, 0.1, 0.1, 0.1, 0.0, -0.5, 0.0],
            }
        },
    }


def write_telescoping(folder: Path) -> Path:
    """Write telescoping.urdf and telescoping.yaml into ``folder``; returns the preset's path."""
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "telescoping.urdf"
    urdf.write_text(telescoping_urdf())
    preset = folder / "telescoping.yaml"
    preset.write_text(yaml.safe_dump(telescoping_preset(str(urdf)), sort_keys=False))
    return preset


def telescoping_robot(folder: Path) -> placement.robots.Robot:
    """The robot, loaded from a preset written into ``folder``."""
    return placement.load_robot(write_telescoping(folder))
