"""`placement scenes check`: a scene read as the planner reads it, summarised; a bad one is one line."""

from __future__ import annotations

import json
from pathlib import Path

from click.testing import CliRunner

from placement.cli.main import cli

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str):
    return CliRunner().invoke(cli, ["scenes", "check", *args])


def test_a_scene_is_summarised_as_json():
    result = run(str(ROOT / "examples" / "kitchen.yaml"), "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["scene"] == "kitchen" and doc["version"] == 2 and doc["robot"] == "pr2"
    assert doc["task"][0] == {"reach": ["drawer_left", "drawer_right"]}
    assert {"pick": "cup", "place": "side_table_spot"} in doc["task"]
    assert (doc["objects"], doc["place_locations"]) == (3, 3)


def test_a_building_scene_names_its_occupancy_map():
    result = run(str(ROOT / "examples" / "buildings" / "wrs_arena" / "tidy_up.yaml"), "--json")
    assert result.exit_code == 0, result.output
    occupancy = json.loads(result.stdout)["occupancy_map"]
    assert occupancy["path"].endswith(".yaml") and min(occupancy["cells"]) > 10 and occupancy["resolution_m"] > 0


def test_the_table_says_what_the_task_asks():
    result = run(str(ROOT / "examples" / "table_clearing.yaml"))
    assert result.exit_code == 0
    assert "table_clearing (version 1)" in result.stdout and "->" in result.stdout


def test_an_unknown_key_is_one_line_naming_it(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("versoin: 1\n")
    result = run(str(bad))
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "unknown key 'versoin'" in result.stderr and str(bad) in result.stderr


def test_a_missing_file_is_one_line(tmp_path):
    result = run(str(tmp_path / "nope.yaml"))
    assert result.exit_code == 2 and result.stderr.startswith("error: ") and "does not exist" in result.stderr


def test_a_task_over_the_documented_limit_is_refused_before_parsing(tmp_path):
    from placement.scene.limits import MAX_TASK

    bad = tmp_path / "long.yaml"
    task = "\n".join(f"  - {{pick: o{i}, place: p}}" for i in range(MAX_TASK + 1))
    bad.write_text(f"version: 1\nrobot: {{preset: pr2, start: [0, 0, 0]}}\ntask:\n{task}\n")
    result = run(str(bad))
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert f"{MAX_TASK + 1} entries, more than the {MAX_TASK} allowed" in result.stderr and "task" in result.stderr


def test_out_of_memory_names_only_options_the_command_has(monkeypatch, tmp_path):
    """A command that runs out of memory says what of its own would shrink the work; one without such
    options says the input is too large (robots init has no --resolution)."""
    import placement.cli.scenes_check as scenes_check

    def exhausted(path):
        raise MemoryError

    monkeypatch.setattr(scenes_check, "summary", exhausted)
    result = run(str(ROOT / "examples" / "kitchen.yaml"))
    assert result.exit_code == 2 and result.stderr.count("\n") == 1
    assert "out of memory in" in result.stderr and "scenes check" in result.stderr
    assert "--resolution" not in result.stderr and "--samples" not in result.stderr
