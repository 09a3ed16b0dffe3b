"""Builds that cannot clobber each other: concurrent builds into one map end both complete or one with a
clear error, nothing is lost, and an output that cannot be written fails before any sampling."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import placement
from placement import MapError
from placement.cli.main import cli
from placement.storage.lock import FileLock

ROOT = Path(__file__).resolve().parents[1]
BUILD = ["--robot", "pr2", "--samples", "3000", "--resolution", "0.2", "--bins", "4,3,4", "--seed", "2", "-q"]
BIG = "1000000000"  # a build this size takes many minutes: an error that comes quickly came before sampling


def _default_sigint() -> None:
    # a pytest-xdist worker ignores SIGINT, and a child inherits that: it would never stop on it
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def start(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "placement.cli.main", "maps", "build", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
        preexec_fn=_default_sigint,
    )


def finish(p: subprocess.Popen, timeout: float = 120) -> tuple[int, str]:
    _, err = p.communicate(timeout=timeout)
    return p.returncode, err


def hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.slow
def test_two_builds_of_different_arms_into_one_map_both_land(tmp_path):
    out = tmp_path / "m"
    builds = [start(*BUILD, "--arm", arm, "--out", str(out)) for arm in ("right", "left")]
    for p in builds:
        code, err = finish(p)
        assert code == 0, err
    for arm in ("right", "left"):
        placement.open_map(out, arm).verify()
    assert hidden(tmp_path) == [], "lock or partial files left behind"


@pytest.mark.slow
def test_a_second_build_of_an_arm_being_built_fails_at_once(tmp_path, pr2, left_map):
    """The first build holds its arms while it samples; the second fails in seconds naming it; the first,
    interrupted, leaves the old map as it was (nothing lost) and no lock behind."""
    out = placement.save_maps(tmp_path / "m", pr2, {"left": left_map})
    before = placement.open_map(out, "left").values
    first = start("--robot", "pr2", "--samples", BIG, "--resolution", "0.2", "--bins", "4,3,4", "-q", "--out", str(out))
    try:
        lock = tmp_path / ".m.arm-right.lock"
        deadline = time.monotonic() + 60
        while not lock.exists():
            assert first.poll() is None, first.communicate()[1]
            assert time.monotonic() < deadline, "the first build never reserved its arms"
            time.sleep(0.1)
        t0 = time.monotonic()
        result = CliRunner().invoke(
            cli, ["maps", "build", *BUILD, "--arm", "right", "--out", str(out)], catch_exceptions=False
        )
        assert result.exit_code == 2, result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and "arm 'right' is being written by another build" in lines[0], result.output
        assert f"pid {first.pid}" in lines[0]
        assert time.monotonic() - t0 < 30
    finally:
        first.send_signal(signal.SIGINT)
        try:
            first.communicate(timeout=60)
        except subprocess.TimeoutExpired:  # never leave a billion-sample build running
            first.kill()
            first.communicate()
            raise
    np.testing.assert_array_equal(placement.open_map(out, "left").values, before)
    assert hidden(tmp_path) == []


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["zarr", "hdf5"])
def test_concurrent_saves_in_threads_keep_every_arm(tmp_path, pr2, right_map, left_map, fmt):
    """save_maps from two threads at once (one arm each), again and again: the map always holds both."""
    for i in range(2):
        out = tmp_path / f"m{i}{placement.storage.backend(fmt).suffix}"
        errors = []

        def save(arm, m, out=out, errors=errors):
            try:
                placement.save_maps(out, pr2, {arm: m}, fmt)
            except Exception as exc:
                errors.append(exc)

        threads = [threading.Thread(target=save, args=a) for a in (("right", right_map), ("left", left_map))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        assert errors == []
        for arm, m in (("right", right_map), ("left", left_map)):
            np.testing.assert_array_equal(placement.open_map(out, arm).values, m.values)


def test_concurrent_saves_of_one_arm(tmp_path, pr2, right_map):
    """Two saves of the same arm at once: each lands whole or fails naming the other; the map is sound."""
    out = tmp_path / "m"
    outcomes = []

    def save():
        try:
            placement.save_maps(out, pr2, {"right": right_map})
            outcomes.append("saved")
        except MapError as exc:
            assert "is being written by another build" in str(exc)
            outcomes.append("refused")

    threads = [threading.Thread(target=save) for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    assert "saved" in outcomes and len(outcomes) == 2
    placement.open_map(out, "right").verify()
    assert hidden(tmp_path) == []


def test_a_stale_lock_of_a_killed_build_is_taken_over(tmp_path, pr2, right_map):
    out = tmp_path / "m"
    (tmp_path / ".m.arm-right.lock").write_text("a build of arm 'right' (pid 1)")  # no one holds it
    placement.save_maps(out, pr2, {"right": right_map})
    placement.open_map(out, "right").verify()
    assert hidden(tmp_path) == []


def test_a_held_lock_names_its_holder(tmp_path, pr2, right_map):
    out = tmp_path / "m"
    with FileLock(tmp_path / ".m.arm-right.lock", "a build of arm 'right' into m (pid 4242)"):
        with pytest.raises(
            MapError,
            match=r"arm 'right' is being written by another build \(a build of arm "
            r"'right' into m \(pid 4242\)",
        ):
            placement.save_maps(out, pr2, {"right": right_map})
    assert not out.exists()


@pytest.mark.parametrize("where", ["long name", "proc"])
def test_an_output_that_cannot_be_written_fails_before_sampling(tmp_path, where):
    """A name whose partial path is too long for the file system (it failed only after the sampling), a
    pseudo file system: exit 2 within seconds although the build would take many minutes."""
    out = tmp_path / ("m" * 250) if where == "long name" else Path("/proc/placement-test/m")
    t0 = time.monotonic()
    result = CliRunner().invoke(
        cli,
        ["maps", "build", "--robot", "pr2", "--arm", "right", "--samples", BIG, "--out", str(out)],
        catch_exceptions=False,
    )
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --out "), result.output
    assert time.monotonic() - t0 < 45
    if where == "long name":
        assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("kind", ["fifo", "dev-zero", "huge"])
def test_a_build_spec_that_is_no_regular_file_of_sane_size_is_not_read(tmp_path, kind):
    from placement.errors import PlacementError
    from placement.maps.buildspec import MAX_SPEC_BYTES, load_build_spec

    spec = tmp_path / "spec.yaml"
    if kind == "fifo":
        os.mkfifo(spec)
    elif kind == "dev-zero":
        spec.symlink_to("/dev/zero")
    else:
        with open(spec, "wb") as fh:
            fh.truncate(MAX_SPEC_BYTES + 1)
    outcome = []
    thread = threading.Thread(
        target=lambda: outcome.append(pytest.raises(PlacementError, load_build_spec, spec)), daemon=True
    )
    thread.start()
    thread.join(30)
    assert not thread.is_alive(), "blocked reading the spec"
    assert outcome and "refusing to read it" in str(outcome[0].value)
