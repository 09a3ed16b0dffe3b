"""tools/onboard_robots.py's table: a run of a few robots keeps the earlier rows of the others (their
maps take long to build) and replaces its own robots' rows, read back from the Markdown it wrote."""

from __future__ import annotations

import sys
from pathlib import Path

TOOLS = Path(__file__).resolve().parents[1] / "tools"
sys.path.insert(0, str(TOOLS))

from onboard_robots import KEYS, lift_key, markdown_table, merge_rows, read_rows  # noqa: E402


def row(robot: str, result: str) -> dict:
    return {"robot": robot, "arms": "arm", "dof": "7", "init s": "1.0", "build s": "-", "result": result} | {
        "steps planned / verified": "8/8 / 8"
    }


def test_a_run_keeps_the_other_rows_and_replaces_its_own(tmp_path):
    path = tmp_path / "onboarding.md"
    assert read_rows(path) == []
    old = [row("tiago", "ok"), row("talos_reduced", "ok"), row("romeo", "old")]
    path.write_text(markdown_table(KEYS, [[r[k] for k in KEYS] for r in old]))
    assert read_rows(path) == old
    new = [row("centauro", "ok"), row("romeo", "new")]
    merged = merge_rows(read_rows(path), new)
    assert [r["robot"] for r in merged] == ["tiago", "talos_reduced", "romeo", "centauro"]
    assert merged[2]["result"] == "new" and merged[0] == old[0]
    assert merge_rows([], new) == new


def test_a_new_build_spec_records_the_lift_settings():
    """The spec written for a robot with a lift carrying its arms chooses its lift per step; a robot
    without one gets no key (and the key it gets parses and checks against the robot)."""
    import yaml

    from placement.maps.buildspec import parse_build_spec
    from placement.robots import load_robot

    pr2 = load_robot("pr2")
    spec = parse_build_spec({"robot": "pr2", **yaml.safe_load(lift_key(pr2))})
    assert spec.torso is not None and spec.torso.joint == "torso_lift_joint"
    assert spec.torso.values == (0.0, 0.15, 0.31)
    tiago = load_robot(str(Path(__file__).parents[1] / "examples" / "robots" / "tiago.yaml"))
    assert "values: [0, 0.175, 0.35]" in lift_key(tiago)  # held at its top: the middle added
    so_arm = load_robot(str(Path(__file__).parents[1] / "examples" / "robots" / "so_arm_base.yaml"))
    assert lift_key(so_arm) == ""
