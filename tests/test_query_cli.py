"""`placement query` and `placement-query`: the same command, strict JSON, one-line errors, no work wasted."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from support.cli import assert_one_line_error, run
from support.planning import SCENE, write_scene
from support.plans import strip_timings


@pytest.mark.slow
def test_placement_query_console_script_equals_placement_query(tmp_path, maps_dir):
    exe = shutil.which("placement-query", path=str(Path(sys.executable).parent))
    assert exe, "the placement-query console script is not installed (pip install -e .)"
    path = write_scene(tmp_path, maps_dir)
    a = subprocess.run([exe, str(path), "--json", "-q"], capture_output=True, text=True)
    b = run("query", str(path), "--json", "-q")
    assert a.returncode == b.returncode == 0, a.stderr + b.stderr
    assert strip_timings(json.loads(a.stdout)) == strip_timings(json.loads(b.stdout))
    h = subprocess.run([exe, "--help"], capture_output=True, text=True)
    assert h.returncode == 0 and "--method" in h.stdout and "--stream" in h.stdout


@pytest.mark.slow
def test_a_query_counts_building_its_planner_against_the_budget(tmp_path, maps_dir):
    """With 0.1 s for the task, building the planner (scene, maps, world, slices read ahead) takes it
    all: the query stops at its first step, which says the budget ran out (exit 3, JSON on stdout)."""
    path = write_scene(tmp_path, maps_dir, planner={"time_budget_s": 0.1})
    got = run("query", str(path), "--json", "-q")
    assert got.returncode == 3, got.stderr
    doc = json.loads(got.stdout)
    assert "time budget of 0.1 s ran out" in doc["steps"][0]["reason"]


@pytest.mark.slow
@pytest.mark.parametrize(
    "changes, words",
    [
        ({"planner": {"lambda_m": 1e308}}, ["planner.lambda_m", "<= 1e+06"]),
        ({"planner": {"threshold": 0}}, ["planner.threshold", "> 0"]),
        (
            {
                "objects": [
                    {"name": "cup", "position": [3.0, 2.5, 0.5], "size": [0.06, 0.06, 0.1]},
                    {"name": "box", "position": [2.8, 2.4, 0.8], "yaw": 1.0, "size": [0.05, 0.12, 0.1]},
                ]
            },
            ["objects[0]", "inside obstacle 'table'"],
        ),
        (
            {"place_locations": [{"name": "spot", "position": [1.0, 0.8, 0.5]}]},
            ["place_locations[0].position", "inside obstacle 'shelf'"],
        ),
        ({"bounds": [0, 0, 1e9, 1e9]}, ["bounds[2]"]),
        ({"bounds": [0, 0, 400, 400]}, ["resolution", "at most 5e+06"]),
        ({"robot": {"preset": "pr2", "start": [3.0, 2.5, 0.0]}}, ["start pose", "inside an obstacle"]),
        ({"maps": "/nonexistent/maps"}, ["/nonexistent/maps"]),
    ],
)
def test_bad_scenes_are_one_line(tmp_path, maps_dir, changes, words):
    assert_one_line_error(run("query", str(write_scene(tmp_path, maps_dir, **changes)), "--json", "-q"), *words)


@pytest.mark.slow
def test_plot_dir_below_a_file_fails_before_planning(tmp_path, maps_dir):
    (tmp_path / "file").write_text("x")
    p = run("query", str(write_scene(tmp_path, maps_dir)), "--plot", str(tmp_path / "file" / "plots"), "-q")
    assert_one_line_error(p, "--plot", "file")
    assert p.stdout == ""  # nothing planned, nothing printed


@pytest.mark.slow
def test_missing_maps_name_where_they_were_looked_for(tmp_path):
    doc = json.loads(json.dumps(SCENE))
    path = tmp_path / "deep" / "scene.yaml"
    path.parent.mkdir()
    path.write_text(yaml.safe_dump(doc))
    p = run("query", str(path), "-q", cwd=tmp_path)
    assert_one_line_error(p, "no maps for robot 'pr2'", str(tmp_path / "deep" / "maps" / "pr2"))


@pytest.mark.slow
def test_maps_are_found_beside_the_scene_from_any_directory(tmp_path, maps_dir):
    """A scene without ``maps:`` finds ``maps/<robot>`` in its folder or a parent, wherever it is run."""
    root = tmp_path / "project"
    (root / "maps").mkdir(parents=True)
    (root / "maps" / "pr2").symlink_to(maps_dir, target_is_directory=True)
    (root / "scenes").mkdir()
    path = root / "scenes" / "scene.yaml"
    path.write_text(yaml.safe_dump(json.loads(json.dumps(SCENE))))
    p = run("query", str(path), "--json", "-q", cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["status"] == "ok"


def test_unknown_option_and_command_are_one_line(tmp_path):
    assert_one_line_error(run("query", "x.yaml", "--method", "best"), "--method", "best")
    assert_one_line_error(run("frobnicate"), "frobnicate")


def _step(i: int, lift: float) -> dict:
    return {
        "step": i,
        "action": "pick",
        "target": f"cup_{i}",
        "arm": "right",
        "grasp": "top",
        "base": [1.0, 2.0, 0.5],
        "joints": {"r_shoulder_pan_joint": 0.1, "torso_lift_joint": lift},
        "configuration": {"fixed_joints": ["torso_lift_joint"]},
        "manipulability": 0.05,
        "cost": {"total": 0.1},
        "travel_time_s": 1.0,
        "timings_ms": {"total": 3.0},
    }


def test_the_table_shows_a_lift_the_plan_moves():
    from placement.cli.query import _table

    plan = {"scene": "s", "method": "global", "robot": {"name": "pr2"}, "steps": [_step(0, 0.31), _step(1, 0.0)]}
    lines = _table(plan).splitlines()
    assert "torso_lift_joint [m]" in lines[1]
    assert lines[2].split()[8] == "0.310" and lines[3].split()[8] == "0.000"
    held = {**plan, "steps": [_step(0, 0.15), _step(1, 0.15)]}
    assert "torso_lift_joint" not in _table(held)
