"""A small robot with a revolute torso pitch joint that carries its arm: a box base, ``torso_pitch``
(about y, 0.6 m above the floor, -0.3 .. 0.8 rad, 0.4 rad/s) with a 0.6 m torso, and a 6-joint arm
(the toy arm of support/toy_robot.py) at its top, 1.2 m above the floor upright. Leaning forward by 0.6
rad moves the shoulder 0.34 m forward and 0.1 m down, so the arm reaches about 0.35 m farther across a
table. Optionally a second arm on the base, which the torso does not carry. Written for the tests of
one map build per torso setting; not a model of a real robot.
"""

from __future__ import annotations

from pathlib import Path

import yaml

import placement

JOINT = "torso_pitch"
LOW, HIGH = -0.3, 0.8  # [rad]
SPEED = 0.4  # [rad/s]
#: (axis, offset from the parent [m]) of the six arm joints
ARM = (
    ("0 0 1", "0 0 0"),
    ("0 1 0", "0 0 0.1"),
    ("0 1 0", "0.3 0 0"),
    ("1 0 0", "0.3 0 0"),
    ("0 1 0", "0.05 0 0"),
    ("1 0 0", "0.05 0 0"),
)
TCP = [0.0, 0.0, 0.0, 0.0, 0.7071067811865476, 0.0, 0.7071067811865476]  # TCP z along the tool's x


def _arm(prefix: str, parent: str, mount: str) -> list[str]:
    parts = []
    for i, (axis, xyz) in enumerate(ARM):
        link = f"{prefix}link_{i + 1}"
        parts += [
            f'<link name="{link}"/>',
            f'<joint name="{prefix}joint_{i + 1}" type="revolute"><parent link="{parent}"/><child link="{link}"/>'
            f'<origin xyz="{mount if i == 0 else xyz}"/><axis xyz="{axis}"/>'
            '<limit lower="-2.5" upper="2.5" effort="10" velocity="1"/></joint>',
        ]
        parent = link
    return parts + [
        f'<link name="{prefix}tool_frame"/>',
        f'<joint name="{prefix}tool_joint" type="fixed"><parent link="{parent}"/><child link="{prefix}tool_frame"/>'
        '<origin xyz="0.12 0 0"/></joint>',
    ]


def pitch_torso_urdf(second_arm: bool = False) -> str:
    """URDF text of the robot (see the module docstring); lengths in metres, angles in radians."""
    parts = [
        '<robot name="pitch_torso">',
        '<link name="base_footprint"/>',
        '<link name="base_link"><collision><geometry><box size="0.5 0.4 0.3"/></geometry></collision></link>',
        '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
        '<origin xyz="0 0 0.15"/></joint>',
        '<link name="torso_link"/>',
        f'<joint name="{JOINT}" type="revolute"><parent link="base_link"/><child link="torso_link"/>'
        f'<origin xyz="0 0 0.45"/><axis xyz="0 1 0"/>'
        f'<limit lower="{LOW}" upper="{HIGH}" effort="100" velocity="{SPEED}"/></joint>',
        '<link name="chest"/>',
        '<joint name="chest_joint" type="fixed"><parent link="torso_link"/><child link="chest"/>'
        '<origin xyz="0 0 0.6"/></joint>',
        *_arm("", "chest", "0 0 0"),
    ]
    if second_arm:
        parts += _arm("b_", "base_link", "0.2 0 0.2")
    parts.append("</robot>")
    return "\n".join(parts)


def pitch_torso_preset(urdf: str, held: float = 0.0, second_arm: bool = False) -> dict:
    """The preset mapping for the URDF file ``urdf``: arm ``arm`` (and ``base_arm``), the torso held at
    ``held`` [rad]."""
    arms = {"arm": {"joints": [f"joint_{i}" for i in range(1, 7)], "tip_frame": "tool_frame"}}
    if second_arm:
        arms["base_arm"] = {"joints": [f"b_joint_{i}" for i in range(1, 7)], "tip_frame": "b_tool_frame"}
    for a in arms.values():
        a |= {"tcp_offset": list(TCP), "home": [0.0, 0.3, 1.2, 0.0, 0.8, 0.0]}
    return {
        "name": "pitch_torso",
        "urdf": urdf,
        "base_frame": "base_footprint",
        "fixed_joints": {JOINT: held},
        "footprint_radius": 0.3,
        "v_max": 0.5,
        "omega_max": 1.0,
        "arms": arms,
    }


def write_pitch_torso(folder: Path, held: float = 0.0, second_arm: bool = False, **changes: object) -> Path:
    """Write pitch_torso.urdf and pitch_torso.yaml (the preset, with top-level ``changes``) into ``folder``;
    returns the preset's path."""
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "pitch_torso.urdf"
    urdf.write_text(pitch_torso_urdf(second_arm))
    preset = folder / "pitch_torso.yaml"
    spec = pitch_torso_preset(str(urdf), held, second_arm) | changes
    preset.write_text(yaml.safe_dump(spec, sort_keys=False))
    return preset


def pitch_torso_robot(folder: Path, held: float = 0.0, second_arm: bool = False, **changes: object):
    """The robot, loaded from a preset written into ``folder``."""
    return placement.load_robot(write_pitch_torso(folder, held, second_arm, **changes))


#: [rad] the settings the tests' maps are built at: upright (the preset's) and leaning forward
SETTINGS = (0.0, 0.6)


def pitch_torso_maps(folder: Path) -> tuple[placement.Robot, Path, Path]:
    """(robot, preset path, maps path): the toy robot's arm mapped at both :data:`SETTINGS`, 0.1 m
    cells (200 k samples, seed 2), written into ``folder``."""
    from placement.maps.buildspec import TorsoSpec
    from placement.maps.torso_builds import build_torso_maps

    preset = write_pitch_torso(folder / "robot")
    robot = placement.load_robot(preset)
    built = build_torso_maps(
        robot,
        "arm",
        torso=TorsoSpec(JOINT, SETTINGS),
        samples=200_000,
        seed=2,
        resolution=0.1,
        bins=(8, 5, 8),
        progress=False,
    )
    return robot, preset, placement.save_maps(folder / "maps", robot, built)
