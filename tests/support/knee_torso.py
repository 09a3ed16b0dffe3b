"""A small robot whose arm rides on a torso of two pitch joints, hip and knee-like: a box base,
``hip_pitch`` (about y, 0.6 m above the floor, -0.3 .. 1.0 rad, 0.4 rad/s) with a 0.6 m lower segment,
``knee_pitch`` (about y, -1.0 .. 0.3 rad, 0.7 rad/s) with a 0.1 m upper segment, and the 6-joint toy arm
of support/pitch_torso.py at its top, 1.3 m above the floor upright. In the posture (0.9, -0.9) rad the
knee undoes the hip's lean: the chest stays upright and moves 0.47 m forward and 0.23 m down, so the arm
reaches about 0.45 m farther across a table without tilting. Written for the tests of torso postures; not
a model of a real robot.
"""

from __future__ import annotations

from pathlib import Path

import yaml

import placement
from support.pitch_torso import TCP, _arm

HIP, KNEE = "hip_pitch", "knee_pitch"
HIP_LIMITS, KNEE_LIMITS = (-0.3, 1.0), (-1.0, 0.3)  # [rad]
HIP_SPEED, KNEE_SPEED = 0.4, 0.7  # [rad/s]
UPRIGHT, CROUCH = (0.0, 0.0), (0.9, -0.9)  # [rad] (hip, knee)


def knee_torso_urdf() -> str:
    """URDF text of the robot (see the module docstring); lengths in metres, angles in radians."""

    def pitch(name: str, parent: str, child: str, z: float, limits: tuple[float, float], speed: float) -> str:
        return (
            f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="0 0 {z}"/><axis xyz="0 1 0"/>'
            f'<limit lower="{limits[0]}" upper="{limits[1]}" effort="100" velocity="{speed}"/></joint>'
        )

    return "\n".join(
        [
            '<robot name="knee_torso">',
            '<link name="base_footprint"/>',
            '<link name="base_link"><collision><geometry><box size="0.5 0.4 0.3"/></geometry></collision></link>',
            '<joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/>'
            '<origin xyz="0 0 0.15"/></joint>',
            '<link name="thigh"/>',
            pitch(HIP, "base_link", "thigh", 0.45, HIP_LIMITS, HIP_SPEED),
            '<link name="trunk"/>',
            pitch(KNEE, "thigh", "trunk", 0.6, KNEE_LIMITS, KNEE_SPEED),
            '<link name="chest"/>',
            '<joint name="chest_joint" type="fixed"><parent link="trunk"/><child link="chest"/>'
            '<origin xyz="0 0 0.1"/></joint>',
            *_arm("", "chest", "0 0 0"),
            "</robot>",
        ]
    )


def write_knee_torso(folder: Path, held: tuple[float, float] = UPRIGHT) -> Path:
    """Write knee_torso.urdf and knee_torso.yaml (the preset: arm ``arm``, hip and knee held at ``held``
    [rad]) into ``folder``; returns the preset's path."""
    folder.mkdir(parents=True, exist_ok=True)
    urdf = folder / "knee_torso.urdf"
    urdf.write_text(knee_torso_urdf())
    preset = folder / "knee_torso.yaml"
    arm = {
        "joints": [f"joint_{i}" for i in range(1, 7)],
        "tip_frame": "tool_frame",
        "tcp_offset": list(TCP),
        "home": [0.0, 0.3, 1.2, 0.0, 0.8, 0.0],
    }
    spec = {
        "name": "knee_torso",
        "urdf": str(urdf),
        "base_frame": "base_footprint",
        "fixed_joints": {HIP: held[0], KNEE: held[1]},
        "footprint_radius": 0.3,
        "v_max": 0.5,
        "omega_max": 1.0,
        "arms": {"arm": arm},
    }
    preset.write_text(yaml.safe_dump(spec, sort_keys=False))
    return preset


def knee_torso_robot(folder: Path, held: tuple[float, float] = UPRIGHT):
    """The robot, loaded from a preset written into ``folder``."""
    return placement.load_robot(write_knee_torso(folder, held))
