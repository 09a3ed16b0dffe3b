"""The command line: JSON on stdout, one-line errors, and the README quick start verbatim."""

from __future__ import annotations

import json
import os
import re
import shlex

import pytest
from support.cli import ROOT, assert_one_line_error, run


@pytest.mark.slow
def test_build_info_json(tmp_path):
    out = tmp_path / "m"
    p = run(
        "maps",
        "build",
        "--robot",
        "pr2",
        "--arm",
        "left",
        "--samples",
        "3000",
        "--resolution",
        "0.1",
        "--out",
        str(out),
        "--json",
        "-q",
    )
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["arms"]["left"]["samples"] == 3000
    p = run("maps", "info", str(out), "--json")
    info = json.loads(p.stdout)
    arm = info["arms"]["left"]
    import placement

    values = placement.open_map(out, "left").values
    assert arm["filled_cells"] == int((values > 0).sum()) > 0
    assert arm["fill_ratio"] == pytest.approx(arm["filled_cells"] / values.size)
    assert sum(arm["value"]["histogram"]["counts"]) == arm["filled_cells"]
    assert arm["meta"]["robot"] == "pr2" and arm["meta"]["seed"] == 0


@pytest.mark.slow
@pytest.mark.parametrize(
    "args,words",
    [
        (["maps", "build", "--robot", "pr3", "--out", "X"], ["pr3"]),
        (["maps", "build", "--arm", "middle", "--out", "X"], ["middle", "right", "left"]),
        (["maps", "build", "--samples", "0", "--out", "X"], ["samples"]),
        (["maps", "build", "--resolution", "-1", "--out", "X"], ["resolution"]),
        (["maps", "build", "--bins", "3,4,5", "--samples", "10", "--out", "X"], ["even"]),
        (["maps", "info", "does-not-exist"], ["does-not-exist"]),
    ],
)
def test_bad_input_is_one_line(tmp_path, args, words):
    args = [str(tmp_path / a) if a == "X" else a for a in args]
    assert_one_line_error(run(*args, cwd=tmp_path), *words)


@pytest.mark.slow
def test_build_refuses_to_overwrite_non_map(tmp_path):
    target = tmp_path / "precious"
    target.mkdir()
    (target / "thesis.txt").write_text("do not delete")
    assert_one_line_error(run("maps", "build", "--samples", "10", "--out", str(target)), "not a map")
    assert (target / "thesis.txt").read_text() == "do not delete"


@pytest.mark.slow
def test_bad_preset_names_the_key(tmp_path):
    preset = tmp_path / "r.yaml"
    preset.write_text("name: r\nurdf: x.urdf\nbase_frame: b\narms: {}\nwheels: 4\n")
    assert_one_line_error(run("maps", "build", "--robot", str(preset), "--out", str(tmp_path / "m")), "wheels")
    preset.write_text(
        "name: r\nurdf: x.urdf\nbase_frame: b\nfootprint_radius: 0.4\nv_max: 0.5\nomega_max: 1.0\n"
        "arms: {a: {joints: [j1, j2, j3, j4, j5, j6], tip_frame: t}}\n"
    )
    assert_one_line_error(run("maps", "build", "--robot", str(preset), "--out", str(tmp_path / "m")), "URDF")
    (tmp_path / "x.urdf").write_text("<robot name='r'><link name='l'/><joint")
    assert_one_line_error(run("maps", "build", "--robot", str(preset), "--out", str(tmp_path / "m")), "URDF")


@pytest.mark.slow
def test_bad_frame_names_the_frame(tmp_path):
    from placement.robots.preset import PRESET_DIR

    text = (
        (PRESET_DIR / "pr2.yaml")
        .read_text()
        .replace("tip_frame: r_gripper_tool_frame", "tip_frame: r_gripper_tool_fram")
    )
    text = text.replace("package://", "package://")
    preset = tmp_path / "pr2x.yaml"
    preset.write_text(text)
    assert_one_line_error(
        run("maps", "build", "--robot", str(preset), "--samples", "10", "--out", str(tmp_path / "m")),
        "r_gripper_tool_fram",
        "r_gripper_tool_frame",
    )


def _readme_blocks(lang):
    text = (ROOT / "README.md").read_text()
    start = text.index("## Quick start")
    end = text.index("\n## ", start + 5)
    return re.findall(rf"```{lang}\n(.*?)```", text[start:end], re.S)


@pytest.mark.slow
def test_readme_quick_start(tmp_path):
    """Every `placement` command of the quick start runs as written (paths moved into tmp)."""
    (bash,) = _readme_blocks("bash")
    commands = [ln.split("#")[0].strip() for ln in bash.splitlines()]
    placement_cmds = [c for c in commands if c.startswith(".venv/bin/placement")]
    assert len(placement_cmds) >= 3
    assert any(c.startswith("make test") for c in commands)
    for cmd in placement_cmds:
        args = shlex.split(cmd)[1:]
        p = run(*args, cwd=tmp_path)
        assert p.returncode == 0, (cmd, p.stderr[-2000:])
        if "--json" in args:
            json.loads(p.stdout)
    (py,) = _readme_blocks("python")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        ns: dict = {}
        exec(compile(py, "README.md", "exec"), ns)
        assert ns["rmap"].value(ns["T"]).shape == (1,)
    finally:
        os.chdir(cwd)


@pytest.mark.slow
def test_unreachable_dask_scheduler_is_one_line(tmp_path):
    pytest.importorskip("dask.distributed")
    assert_one_line_error(
        run("maps", "build", "--samples", "10", "--dask", "tcp://127.0.0.1:9", "--out", str(tmp_path / "m")),
        "Dask scheduler",
    )


def test_python_warnings_become_one_line_on_stderr(capsys):
    import warnings

    from placement.cli.options import setup_logging

    saved = warnings.showwarning
    try:
        setup_logging(0, False)
        with warnings.catch_warnings():
            warnings.simplefilter("always")
            warnings.warn("robot 'r': links without their collision meshes: a,\nb", UserWarning, stacklevel=1)
    finally:
        warnings.showwarning = saved
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("warning: robot 'r': links without their collision meshes: a,")
