"""`placement view` and `placement maps view` as a user runs them, and the plan-file parser under
random and mutated documents (either PlanFileError or steps, never another exception)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from support.mutations import documents, mutated

from placement.planning import StepResult
from placement.viewer.plan_file import PlanFileError, parse_plan

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"
ROOT = Path(__file__).resolve().parents[1]
PLAN_KEYS = (
    "steps",
    "robot",
    "name",
    "step",
    "action",
    "target",
    "status",
    "arm",
    "base",
    "tcp",
    "joints",
    "cost",
    "total",
    "manipulability",
    "travel_time_s",
    "grasp",
    "reason",
    "r_shoulder_pan_joint",
)


def run(*args, stdin: str | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "placement.cli.main", *args],
        capture_output=True,
        text=True,
        input=stdin,
        timeout=timeout,
        cwd=ROOT,
    )


@pytest.fixture(scope="module")
def plan_doc(maps_dir) -> dict:
    import placement

    return placement.Planner(EXAMPLE, "sequential", maps_dir).plan().to_json()


def one_line_error(p, *words):
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


@pytest.mark.slow
@pytest.mark.parametrize(
    "args, words",
    [
        (["--plan", "p.json", "--method", "fixed"], ["--plan", "--method"]),
        (["--plan", "p.json", "--stream"], ["--plan", "--stream"]),
        (["--plan", "/nonexistent/plan.json"], ["--plan", "/nonexistent/plan.json", "cannot read"]),
        (["--port", "70000"], ["--port", "70000", "0 to 65535"]),
        (["--method", "best"], ["--method"]),
    ],
)
def test_bad_options_are_one_line(args, words):
    one_line_error(run("view", str(EXAMPLE), *args), *words)


@pytest.mark.slow
def test_bad_plan_files_are_one_line(tmp_path, plan_doc):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    one_line_error(run("view", str(EXAMPLE), "--plan", str(bad)), str(bad), "not JSON")
    doc = json.loads(json.dumps(plan_doc))
    doc["steps"][2]["arm"] = "middle"
    bad.write_text(json.dumps(doc))
    one_line_error(run("view", str(EXAMPLE), "--plan", str(bad)), "steps[2].arm", "middle", "right, left")
    one_line_error(run("maps", "view", str(tmp_path / "nomap")), "nomap")


@pytest.mark.slow
def test_view_serves_until_stopped_and_prints_its_url(maps_dir):
    p = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "placement.cli.main",
            "view",
            str(EXAMPLE),
            "--maps",
            str(maps_dir),
            "--port",
            "0",
            "--json",
            "-q",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    try:
        info = json.loads(p.stdout.readline())
        assert info["url"].startswith("http://127.0.0.1:") and info["timings_s"]["first_step_s"] > 0
        with urllib.request.urlopen(info["url"], timeout=10) as r:
            assert r.status == 200
        p.send_signal(signal.SIGINT)  # Ctrl-C: the normal way to stop
        assert p.wait(timeout=60) == 0
    finally:
        if p.poll() is None:
            p.kill()
    with pytest.raises(OSError):
        urllib.request.urlopen(info["url"], timeout=5)


@pytest.mark.slow
def test_stream_applies_updates_live(maps_dir):
    updates = "\n".join([json.dumps({"start": [1.5, 6.0, 0.0]}), "{oops", json.dumps({"start": [-50, 0, 0]})]) + "\n"
    p = run(
        "view",
        str(EXAMPLE),
        "--maps",
        str(maps_dir),
        "--port",
        "0",
        "--stream",
        "--timeout",
        "0.5",
        "-q",
        stdin=updates,
    )
    assert p.returncode == 0, p.stderr
    lines = [json.loads(x) for x in p.stdout.splitlines()]
    assert len(lines) == 4 and lines[0]["status"] == "ok" and lines[1]["status"] == "ok"
    assert "update" in lines[1] and "error" in lines[2] and "error" in lines[3]
    assert lines[1]["steps"][0]["base"] != lines[0]["steps"][0]["base"] or lines[1]["update"]["updated"]


@pytest.mark.slow
def test_maps_view_runs(maps_dir):
    p = run(
        "maps",
        "view",
        str(maps_dir),
        "--arm",
        "right",
        "--direction",
        "down",
        "--port",
        "0",
        "--json",
        "--timeout",
        "0.5",
        "-q",
    )
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert info["url"].startswith("http://127.0.0.1:") and info["timings_s"]["render_s"] > 0
    one_line_error(run("maps", "view", str(maps_dir), "--arm", "middle", "--port", "0"), "middle", "right")


def check(doc, robot) -> None:
    try:
        steps = parse_plan(doc, "plan.json", robot)
    except PlanFileError as exc:
        assert "\n" not in str(exc) and str(exc).startswith("plan.json")
        return
    assert steps and all(isinstance(s, StepResult) for s in steps)
    for s in steps:
        assert not s.ok or (len(s.base) == 3 and s.tcp.shape[1:] == (4, 4) and s.q.shape == (7,))


@settings(deadline=None, suppress_health_check=list(HealthCheck))
@given(doc=documents(PLAN_KEYS))
def test_random_plan_documents(pr2, doc):
    check(doc, pr2)
    check({"steps": [doc]}, pr2)


VALID = {
    "robot": {"name": "pr2"},
    "steps": [
        {
            "step": 0,
            "action": "pick",
            "target": "cup",
            "arm": "right",
            "grasp": "top",
            "base": [1.0, 2.0, 0.5],
            "tcp": [
                [2.0, 2.0, 0.8, 0.0, 0.0, 0.0, 1.0],
                [2.0, 2.0, 0.75, 0.0, 0.7071067811865476, 0.0, 0.7071067811865476],
            ],
            "joints": {
                f"r_{j}": 0.1
                for j in (
                    "shoulder_pan_joint",
                    "shoulder_lift_joint",
                    "upper_arm_roll_joint",
                    "elbow_flex_joint",
                    "forearm_roll_joint",
                    "wrist_flex_joint",
                    "wrist_roll_joint",
                )
            },
            "manipulability": 0.05,
            "cost": {"total": 0.4, "navigation": 0.2, "manipulation": 0.15, "heuristic": 0.05},
            "travel_time_s": 3.0,
        },
        {"step": 1, "action": "place", "target": "a", "status": "infeasible", "reason": "no placement"},
    ],
}


@settings(deadline=None, suppress_health_check=list(HealthCheck))
@given(doc=mutated(VALID, PLAN_KEYS))
def test_mutated_plan_documents(pr2, doc):
    check(doc, pr2)


def test_the_valid_plan_parses(pr2):
    steps = parse_plan(VALID, "plan.json", pr2)
    assert [s.ok for s in steps] == [True, False] and steps[0].base == (1.0, 2.0, 0.5)
    assert steps[1].reason == "no placement" and steps[0].tcp.shape == (2, 4, 4)
    assert abs(steps[0].cost.total - 0.4) < 1e-12 and steps[0].joints["r_elbow_flex_joint"] == 0.1
