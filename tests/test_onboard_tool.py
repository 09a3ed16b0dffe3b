"""tools/onboard_robots.py's table: a run of a few robots keeps the earlier rows of the others (their
maps take long to build) and replaces its own robots' rows, read back from the Markdown it wrote."""

from __future__ import annotations

import sys
from pathlib import Path

TOOLS = Path(__file__).resolve().parents[1] / "tools"
sys.path.insert(0, str(TOOLS))

from onboard_robots import KEYS, markdown_table, merge_rows, read_rows  # noqa: E402


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
