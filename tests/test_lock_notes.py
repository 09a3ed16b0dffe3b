"""Locks are waited on visibly and with a bound; what a killed build or save left is found, cleared
and said (placement/storage/lock.py, placement/storage/base.py clear_leftovers)."""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import placement
from placement import MapError
from placement.storage.lock import FileLock

ROOT = Path(__file__).resolve().parents[1]


def dead_pid() -> int:
    """The id of a process that has ended."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_a_wait_for_a_live_holder_is_said_and_bounded(tmp_path, caplog):
    path = tmp_path / ".m.save.lock"
    held, release = threading.Event(), threading.Event()

    def hold() -> None:
        with FileLock(path, "a save into m (pid 4242)"):
            held.set()
            release.wait(10)

    t = threading.Thread(target=hold)
    t.start()
    held.wait(5)
    try:
        with caplog.at_level(logging.INFO, logger="placement"):
            t0 = time.monotonic()
            with pytest.raises(MapError, match=r"a save into m \(pid 4242\) holds .*\(waited 2 s\)"):
                FileLock(path, "me").acquire(wait_s=1.6)
            assert time.monotonic() - t0 < 3
    finally:
        release.set()
        t.join(10)
    notes = [r.getMessage() for r in caplog.records if "waiting for" in r.getMessage()]
    assert len(notes) == 1 and "a save into m (pid 4242)" in notes[0] and "at most 2 s" in notes[0]


def test_a_lock_left_by_a_killed_holder_is_taken_over_and_said(tmp_path, caplog):
    path = tmp_path / ".m.save.lock"
    path.write_text(f"a save into m (pid {dead_pid()})")  # nobody holds the flock: its holder is gone
    with caplog.at_level(logging.INFO, logger="placement"):
        with FileLock(path, "me"):
            assert path.read_text() == "me"
    assert any("took over" in r.getMessage() and "ended without releasing it" in r.getMessage() for r in caplog.records)
    assert not path.exists()


def test_a_killed_saves_copies_are_cleared_and_said(tmp_path, pr2, right_map, left_map, caplog):
    out = tmp_path / "m"
    placement.save_maps(out, pr2, {"right": right_map})
    pid = dead_pid()
    (tmp_path / f".m.partial-{pid}-1").mkdir()
    (tmp_path / f".m.partial-{pid}-1" / "junk").write_bytes(b"\0" * 100)
    (tmp_path / f".m.old-{pid}-1").mkdir()
    alive = tmp_path / f".m.partial-{os.getpid()}-99"  # a live process's copy is not ours to remove
    alive.mkdir()
    with caplog.at_level(logging.INFO, logger="placement"):
        placement.save_maps(out, pr2, {"left": left_map})
    said = [r.getMessage() for r in caplog.records if "killed" in r.getMessage()]
    assert len(said) == 2 and all(f"pid {pid}" in s for s in said)
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == [alive.name]
    for arm in ("right", "left"):
        placement.open_map(out, arm).verify()


def test_a_map_moved_aside_by_a_killed_save_is_restored(tmp_path, pr2, right_map, left_map, caplog):
    out = tmp_path / "m"
    placement.save_maps(out, pr2, {"right": right_map})
    os.replace(out, tmp_path / f".m.old-{dead_pid()}-7")  # killed between its two renames
    with caplog.at_level(logging.INFO, logger="placement"):
        placement.save_maps(out, pr2, {"left": left_map})
    assert any(r.getMessage().startswith(f"restored {out}") for r in caplog.records)
    for arm in ("right", "left"):  # the restored map's arm is kept beside the new one
        placement.open_map(out, arm).verify()
    assert [p.name for p in tmp_path.iterdir()] == ["m"]


@pytest.mark.slow
def test_a_build_killed_with_sigkill_never_blocks_the_next(tmp_path):
    out = tmp_path / "m"
    build = [sys.executable, "-m", "placement.cli.main", "maps", "build", "--robot", "pr2", "--arm", "right"]
    grid = ["--resolution", "0.2", "--bins", "4,3,4", "--out", str(out)]
    first = subprocess.Popen([*build, "--samples", "1000000000", *grid, "-q"], cwd=ROOT)
    lock = tmp_path / ".m.arm-right.lock"
    deadline = time.monotonic() + 120
    while not lock.exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert lock.exists()
    first.send_signal(signal.SIGKILL)
    first.wait(30)
    second = subprocess.run([*build, "--samples", "3000", *grid], cwd=ROOT, capture_output=True, text=True)
    assert second.returncode == 0, second.stderr
    assert "took over" in second.stderr and f"pid {first.pid}" in second.stderr
    placement.open_map(out, "right").verify()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m"]
