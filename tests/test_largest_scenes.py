"""The largest scenes a file may hold end in bounded time and memory: each a `placement query` in its
own process (tools/bench_limits.py's scenes, on the test maps, with a 2 s task budget): a plan, or a
partial plan whose first unplanned step names the budget and how to raise it, well within 60 s and
4 GiB on 2 cores; never a traceback."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import bench_limits  # noqa: E402

pytestmark = pytest.mark.slow

CASES = {
    "pairs": lambda doc: doc,
    "yaws": lambda doc: bench_limits.with_planner(doc, grasp_yaws=360),
    "lids": lambda doc: bench_limits.with_planner(bench_limits.lidded(doc), ik_budget_ms=60000),
    "reaches": lambda doc: bench_limits.reaches(doc, 100, 3, 100),
}


@pytest.mark.parametrize(
    "case, method",
    [
        ("pairs", "global"),
        ("pairs", "sequential"),
        ("pairs", "optimal"),
        ("yaws", "global"),
        ("yaws", "sequential"),
        ("lids", "global"),
        ("reaches", "sequential"),
    ],
)
def test_a_largest_scene_ends_within_its_budget(maps_dir, tmp_path, case, method):
    doc = bench_limits.with_planner(CASES[case](bench_limits.two_rooms(str(maps_dir))), time_budget_s=2.0)
    path = tmp_path / f"{case}.yaml"
    path.write_text(bench_limits.dumped(doc))
    assert path.stat().st_size <= 2 * 2**20
    got = bench_limits.run(path, str(maps_dir), method, limit=60.0)
    assert got["rc"] in (0, 3), got
    assert got["wall"] < 60.0 and got["rss"] is not None and got["rss"] < 4.0, got
    if got["rc"] == 3:
        assert got["said"], got
        if "budget" in got["said"]:
            assert "time budget of 2 s ran out" in got["said"] or "IK budget" in got["said"], got


def test_a_query_past_its_memory_budget_stops_saying_so(maps_dir, tmp_path):
    """The memory budget in a real process: 100 pick/place pairs may add only 10 MiB to the query's
    resident memory (far less than their options take): the query stops at that budget, saying so,
    long before its time budget."""
    doc = bench_limits.with_planner(bench_limits.two_rooms(str(maps_dir)), time_budget_s=60.0, memory_budget_gib=0.01)
    path = tmp_path / "pairs.yaml"
    path.write_text(bench_limits.dumped(doc))
    got = bench_limits.run(path, str(maps_dir), "global", limit=60.0)
    assert got["rc"] == 3 and got["wall"] < 60.0, got
    assert "memory budget of 0.01 GiB ran out" in got["said"] and "planner.memory_budget_gib" in got["said"], got
