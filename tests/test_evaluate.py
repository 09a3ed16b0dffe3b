"""Batch evaluation: the evaluation document, failures counted, report files written."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import yaml
from support.steps import placed_step

from placement.errors import PlacementError
from placement.evaluation.evaluate import check_methods, evaluate, plan_outcome
from placement.evaluation.generate import generate_scene


def _scenes(tmp_path, maps_dir, n=2):
    paths = []
    for k in range(n):
        doc = generate_scene(5, k, objects=2, maps=str(maps_dir))
        doc["planner"] = {
            "threshold": 0.01,
            "yaw_steps": 40,
            "ik_budget_ms": 60000,
            "time_budget_s": 3600,
        }  # load-independent
        p = tmp_path / f"s{k}.yaml"
        p.write_text(yaml.safe_dump(doc))
        paths.append(p)
    return paths


def test_evaluate_document(tmp_path, maps_dir):
    paths = _scenes(tmp_path, maps_dir)
    doc = evaluate(paths, ["sequential", "irm", "fixed"], workers=1)
    assert doc["scenes"] == ["s0", "s1"]
    for m in ("sequential", "irm", "fixed"):
        r = doc["methods"][m]
        assert len(r["task_time_s"]) == len(r["success"]) == len(r["planning_ms_per_placement"]) == 2
        for t, ok, why in zip(r["task_time_s"], r["success"], r["reason"]):
            assert (t is not None) == ok and (why is None) == ok  # a failure is reported, never dropped
    assert all(doc["methods"]["sequential"]["success"])
    # every place by its pick's arm and grasp, upright as picked
    assert all(doc["methods"][m]["transfer_faults"] == [0, 0] for m in ("sequential", "irm", "fixed"))
    red = doc["reductions"]["sequential"]["irm"]
    seq, irm = doc["methods"]["sequential"]["task_time_s"], doc["methods"]["irm"]["task_time_s"]
    assert red == 1 - sum(seq) / sum(irm)


@pytest.mark.slow
def test_cli_evaluate_writes_report(tmp_path, maps_dir):
    paths = _scenes(tmp_path, maps_dir, n=2)
    out = tmp_path / "report"
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "placement.cli.main",
            "evaluate",
            *map(str, paths),
            "--methods",
            "sequential,single-step",
            "--workers",
            "2",
            "--json",
            "-q",
            "--out",
            str(out),
        ],
        capture_output=True,
        text=True,
        env=dict(os.environ),
    )
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert set(doc["methods"]) == {"sequential", "single-step"}
    for f in ("results.json", "summary.md", "summary.csv", "task_times.png"):
        assert (out / f).stat().st_size > 0
    assert sorted(f.name for f in out.iterdir()) == ["results.json", "summary.csv", "summary.md", "task_times.png"]


def test_check_methods():
    assert check_methods(("irm", "sequential")) == ["irm", "sequential"]
    for bad, word in (([], "no method"), (["irm", " "], "empty"), (["irm", "irm"], "twice"), (["IRM"], "unknown")):
        with pytest.raises(PlacementError, match=word):
            check_methods(bad)


def test_library_rejects_bad_workers_before_planning(tmp_path):
    with pytest.raises(PlacementError, match="workers must be a whole number from 1 to 64"):
        evaluate([tmp_path / "missing.yaml"], ["irm"], workers=0)


def test_plan_outcome_names_the_first_infeasible_step():
    from placement.planning import InfeasibleStep, PlanResult

    plan = PlanResult(
        "s",
        "sequential",
        {},
        [
            placed_step(0, "pick", "box"),
            InfeasibleStep(1, "pick", "cup", reason="below threshold"),
            InfeasibleStep(2, "place", "b", reason="no IK"),
        ],
    )
    assert plan_outcome(plan, None) == (3, "step 1 (pick cup): below threshold")
    assert plan_outcome(None, "bad map") == (0, "bad map")
