"""Bad input of `scenes generate` and `evaluate`: one line `error: ...`, exit code 2, nothing created."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from placement.cli.main import cli
from placement.evaluation.generate import MAX_OBJECTS, MAX_SCENES, generate_scene


def run(args):
    return CliRunner().invoke(cli, [str(a) for a in args])


def assert_one_error(result, *words):
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert result.stdout == ""


@pytest.fixture()
def scene_file(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(generate_scene(5, 0, objects=1)))
    return path


@pytest.fixture()
def read_only_dir(tmp_path):
    """A directory nothing can be written into: /sys for root (permissions do not stop root), else chmod."""
    if os.geteuid() == 0:
        yield Path("/sys")
        return
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o555)
    yield d
    d.chmod(0o755)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--count", "1e12"], ["'--count'", "1e12", f"from 1 to {MAX_SCENES}"]),
        (["--count", "1000000000000"], ["'--count'", f"from 1 to {MAX_SCENES}"]),
        (["--count", "0"], ["'--count'", f"from 1 to {MAX_SCENES}"]),
        (["--objects", "100000"], ["'--objects'", f"from 1 to {MAX_OBJECTS}"]),
        (["--objects", "0"], ["'--objects'", f"from 1 to {MAX_OBJECTS}"]),
        (["--objects", "six"], ["'--objects'", "six"]),
        (["--seed", "-1"], ["'--seed'", "from 0 to"]),
        (["--seed", "1.5"], ["'--seed'", "from 0 to"]),
        (["--seed", str(2**63)], ["'--seed'", "from 0 to"]),
        (["--robot", "nope"], ["unknown robot 'nope'"]),
    ],
)
def test_generate_bad_options(tmp_path, args, words):
    out = tmp_path / "out"
    assert_one_error(run(["scenes", "generate", *args, "--out", out]), *words)
    assert not out.exists()


def test_generate_bounds_are_in_the_help():
    text = run(["scenes", "generate", "--help"]).output
    assert f"1 to {MAX_SCENES}" in text and f"1 to {MAX_OBJECTS}" in text and "0 to 2^63-1" in text


def test_generate_out_dir_below_a_file(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("keep")
    assert_one_error(run(["scenes", "generate", "--out", blocker / "a" / "b"]), "--out", str(blocker), "is a file")
    assert_one_error(run(["scenes", "generate", "--out", blocker]), "--out", "not a directory")
    assert blocker.read_text() == "keep" and sorted(tmp_path.iterdir()) == [blocker]


def test_generate_out_dir_read_only(read_only_dir):
    before = sorted(read_only_dir.iterdir())
    assert_one_error(run(["scenes", "generate", "--count", 1, "--out", read_only_dir]), "--out", "cannot write")
    assert_one_error(
        run(["scenes", "generate", "--count", 1, "--out", read_only_dir / "new" / "deeper"]), "--out", "cannot create"
    )
    assert sorted(read_only_dir.iterdir()) == before


def test_generate_failure_after_the_check_leaves_no_directory(tmp_path):
    # a preset file that is not a preset: the robot is loaded (for the default maps) after the check
    bad = tmp_path / "bad.yaml"
    bad.write_text("- 1\n")
    out = tmp_path / "a" / "b"
    result = run(["scenes", "generate", "--robot", bad, "--out", out])
    assert result.exit_code == 2 and result.stderr.startswith("error: ")
    assert not (tmp_path / "a").exists()


@pytest.mark.parametrize(
    ("methods", "words"),
    [
        (",", ["'--methods'", "empty method name", "sequential, single-step"]),
        ("", ["'--methods'", "empty method name"]),
        ("  ", ["'--methods'", "empty method name"]),
        ("sequential,,irm", ["'--methods'", "empty method name"]),
        ("irm,sequential,irm", ["'--methods'", "'irm' is given twice"]),
        ("sequental", ["'--methods'", "unknown method 'sequental'", "choose from"]),
    ],
)
def test_evaluate_bad_methods(tmp_path, scene_file, methods, words):
    out = tmp_path / "report"
    assert_one_error(run(["evaluate", scene_file, "--methods", methods, "--out", out]), *words)
    assert not out.exists()


@pytest.mark.parametrize("workers", ["0", "-3", "65", "two"])
def test_evaluate_bad_workers(tmp_path, scene_file, workers):
    out = tmp_path / "report"
    assert_one_error(run(["evaluate", scene_file, "--workers", workers, "--out", out]), "'--workers'", "from 1 to 64")
    assert not out.exists()


def test_evaluate_out_below_a_file_fails_before_planning(tmp_path, scene_file):
    # no maps exist for this scene: had the evaluation started, the error would be about maps
    blocker = tmp_path / "file"
    blocker.write_text("keep")
    assert_one_error(run(["evaluate", scene_file, "--out", blocker / "report"]), "--out", "is a file")
    assert_one_error(run(["evaluate", scene_file, "--out", blocker]), "--out", "not a directory")
    assert blocker.read_text() == "keep"


def test_evaluate_out_read_only_fails_before_planning(scene_file, read_only_dir):
    before = sorted(read_only_dir.iterdir())
    assert_one_error(run(["evaluate", scene_file, "--out", read_only_dir]), "--out", "cannot write")
    assert_one_error(run(["evaluate", scene_file, "--out", read_only_dir / "r"]), "--out", "cannot create")
    assert sorted(read_only_dir.iterdir()) == before


def test_evaluate_bad_scene_fails_before_planning_and_leaves_no_out(tmp_path, scene_file):
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nobjects: [\n")
    out = tmp_path / "report" / "deep"
    assert_one_error(run(["evaluate", scene_file, bad, "--out", out]), "bad.yaml", "invalid YAML")
    assert not (tmp_path / "report").exists()
    assert_one_error(run(["evaluate", tmp_path / "missing.yaml", "--out", out]), "missing.yaml")
    assert not (tmp_path / "report").exists()
