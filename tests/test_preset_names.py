"""Names `robots init` writes it can read back: any text a URDF may name a robot, link or joint with
(an emoji, a quote, a control character) round-trips through the preset's YAML."""

from __future__ import annotations

import subprocess
import sys

import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from support.toy_robot import arm_urdf

from placement.robots import load_robot
from placement.robots.onboarding.render import quoted


@settings(max_examples=500, deadline=None)
@given(st.text())
def test_any_name_reads_back_as_written(text):
    assert yaml.safe_load(f"key: {quoted(text)}") == {"key": text}


def test_a_robot_with_emoji_names_gets_a_preset_that_loads(tmp_path):
    urdf = (
        arm_urdf("toy🤖", 6).replace('name="joint_1"', 'name="joint_🦾"').replace('joint="joint_1"', 'joint="joint_🦾"')
    )
    (tmp_path / "toy.urdf").write_text(urdf, encoding="utf-8")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "placement.cli.main",
            "robots",
            "init",
            str(tmp_path / "toy.urdf"),
            "--out",
            str(tmp_path / "toy.yaml"),
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    robot = load_robot(str(tmp_path / "toy.yaml"))
    assert robot.name == "toy🤖" and "joint_🦾" in robot.arm(robot.arms[0]).joints
