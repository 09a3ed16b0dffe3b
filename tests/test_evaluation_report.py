"""`placement evaluate --out DIR` writes each report file whole or not at all (through a temporary file
beside it and ``os.replace``)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from placement.cli.evaluate import write_report
from placement.evaluation.outdir import atomic_path, write_text_atomic

REPORT = {"results.json", "summary.md", "summary.csv", "task_times.png"}


def small_doc():
    """An evaluation document of two methods on two scenes (one failed), as evaluate() returns it."""
    method = {"task_time_s": [12.5, None], "success": [True, False], "planning_ms_per_placement": [3.0, 4.0]}
    return {
        "scenes": ["a.yaml", "b.yaml"],
        "methods": {"greedy": dict(method), "fixed": dict(method, task_time_s=[20.0, None])},
        "reductions": {"greedy": {"fixed": 0.375}, "fixed": {"fixed": 0.0}},
    }


@pytest.mark.slow
def test_every_report_file_is_renamed_into_place(tmp_path, monkeypatch):
    moves = []
    real = os.replace

    def recording(src, dst):
        moves.append((Path(src), Path(dst)))
        real(src, dst)

    monkeypatch.setattr(os, "replace", recording)
    write_report(small_doc(), tmp_path)
    assert {dst.name for _, dst in moves} == REPORT
    assert all(src.parent == dst.parent == tmp_path and src.name.startswith(".") for src, dst in moves)
    assert {p.name for p in tmp_path.iterdir()} == REPORT  # no temporary file left
    assert (tmp_path / "summary.md").read_text().startswith("| method |")
    assert b"\r\n" in (tmp_path / "summary.csv").read_bytes()  # the csv module's line ends, untranslated
    assert (tmp_path / "task_times.png").read_bytes().startswith(b"\x89PNG")


def test_a_report_that_fails_to_land_leaves_the_old_files(tmp_path, monkeypatch):
    for name in REPORT:
        (tmp_path / name).write_text("old")

    def failing(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", failing)
    with pytest.raises(OSError, match="No space"):
        write_report(small_doc(), tmp_path)
    assert {p.name: p.read_text() for p in tmp_path.iterdir()} == dict.fromkeys(REPORT, "old")


def test_a_writer_that_raises_halfway_leaves_nothing(tmp_path):
    target = tmp_path / "task_times.png"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".png"  # savefig picks the format by the suffix
        tmp.write_bytes(b"\x89PNG half")
        raise RuntimeError("the plot failed")
    assert list(tmp_path.iterdir()) == []


def test_an_atomic_file_gets_the_default_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        write_text_atomic(tmp_path / "summary.md", "| a |\n")
    finally:
        os.umask(old)
    assert (tmp_path / "summary.md").stat().st_mode & 0o777 == 0o644
    assert (tmp_path / "summary.md").read_text() == "| a |\n"
