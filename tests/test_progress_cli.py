"""Commands that work longer than a few seconds show progress on stderr: evaluate (a bar whose elapsed
time moves during a long scene), maps info (layers read and checked per arm), maps check (IK solves)."""

from __future__ import annotations

import io
import logging
import re
import time

import pytest
from click.testing import CliRunner
from tqdm import tqdm

from placement.progress import Ticking


def _frames(stderr: str) -> list[str]:
    """The successive states of the bars (tqdm redraws a line with carriage returns)."""
    return [f.strip() for f in re.split(r"[\r\n]", stderr) if f.strip()]


def test_a_ticking_bar_redraws_its_elapsed_time_without_updates():
    out = io.StringIO()
    bar = tqdm(total=3, desc="work", file=out, mininterval=0)
    with Ticking(bar, interval=0.1):
        time.sleep(0.55)
    bar.close()
    waiting = [f for f in _frames(out.getvalue()) if f.startswith("work:   0%")]
    assert len(waiting) >= 4  # the first draw and the ticks, no update in between


def test_evaluate_says_what_it_runs_and_its_bar_moves_during_the_first_scene(tmp_path, maps_dir, caplog, monkeypatch):
    import functools

    import placement.cli.evaluate as evaluate_cli
    from placement.cli.main import cli

    # ticks every 50 ms instead of 1 s: a scene that takes about a second still shows several redraws
    monkeypatch.setattr(evaluate_cli, "Ticking", functools.partial(Ticking, interval=0.05))

    runner = CliRunner()
    made = runner.invoke(
        cli,
        [
            "scenes",
            "generate",
            "--seed",
            "3",
            "--count",
            "1",
            "--maps",
            str(maps_dir),
            "--out",
            str(tmp_path / "scenes"),
            "-q",
        ],
    )
    assert made.exit_code == 0, made.output
    with caplog.at_level(logging.INFO, logger="placement"):  # the CLI's log lines (stderr outside pytest)
        out = runner.invoke(
            cli, ["evaluate", str(tmp_path / "scenes"), "--methods", "fixed,sequential", "--workers", "1", "--json"]
        )
    assert out.exit_code == 0, out.stderr
    frames = _frames(out.stderr)
    assert "evaluating 1 scene with fixed, sequential (1 process)" in caplog.messages
    waiting = [f for f in frames if f.startswith("scenes:   0%")]
    assert len(waiting) >= 3, frames  # the first draw and ticks: the bar was redrawn before the scene was done
    assert any(f.startswith("scenes: 100%") for f in frames)


def _on_a_terminal(*args: str, timeout: float = 600) -> tuple[int, str, str]:
    """(exit code, stdout, what the command drew on its terminal) of ``placement ARGS`` whose stderr is
    a pseudo-terminal (the bars of maps info and check are drawn on a terminal only)."""
    import fcntl
    import os
    import pty
    import struct
    import subprocess
    import sys
    import termios
    import threading

    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))  # 120 columns: tqdm draws nothing in 0
    proc = subprocess.Popen(
        [sys.executable, "-m", "placement.cli.main", *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=slave,
    )
    os.close(slave)
    drawn = []

    def read_terminal():
        while True:
            try:
                data = os.read(master, 1 << 16)
            except OSError:  # EIO: the command closed the terminal
                return
            if not data:
                return
            drawn.append(data)

    reader = threading.Thread(target=read_terminal, daemon=True)
    reader.start()
    out, _ = proc.communicate(timeout=timeout)
    reader.join(timeout=10)
    os.close(master)
    return proc.returncode, out.decode(), b"".join(drawn).decode(errors="replace")


@pytest.mark.slow
def test_maps_info_full_shows_the_layers_it_reads_per_arm_on_a_terminal(maps_dir):
    import json

    from placement import open_map

    code, out, terminal = _on_a_terminal("maps", "info", str(maps_dir), "--json", "--full")
    assert code == 0, terminal
    assert set(json.loads(out)["arms"]) == {"right", "left"}  # stdout: the document alone
    frames = _frames(terminal)
    for arm in ("right", "left"):
        nz = open_map(maps_dir, arm).grid.shape[2]
        # a bar per arm over its z layers (tqdm draws at most every 0.1 s, and clears it at the end)
        assert any(f.startswith(f"info {arm}:   0%") and f" 0/{nz} " in f for f in frames), frames
    # not on a pipe, nor with -q: the mixed output of a test runner stays the document
    from placement.cli.main import cli

    plain = CliRunner().invoke(cli, ["maps", "info", str(maps_dir), "--json"])
    assert plain.exit_code == 0 and json.loads(plain.output)


@pytest.mark.slow
def test_maps_check_shows_its_ik_solves_and_reports_as_check_map_does(maps_dir, pr2):
    import json

    from placement import check_map, open_map

    code, out, terminal = _on_a_terminal("maps", "check", str(maps_dir), "--arm", "right", "--samples", "3", "--json")
    assert code == 0, terminal
    frames = _frames(terminal)
    assert "arm right: reading and checking every chunk" in frames
    for what in ("cells", "poses"):  # the cell-level, then the pose-level IK solves
        assert any(f.startswith(f"check right: {what}:") for f in frames), frames

    def untimed(d):
        if isinstance(d, dict):
            return {k: untimed(v) for k, v in d.items() if not (k.endswith("time_s") or k == "ik_ms_per_pose")}
        return [untimed(v) for v in d] if isinstance(d, list) else d

    want = check_map(pr2, open_map(maps_dir, "right").load(), samples=3, seed=0)
    got = json.loads(out)["arms"]["right"]
    assert list(got) == list(want) and untimed(got) == untimed(json.loads(json.dumps(want)))
    assert got["time_s"] >= got["pose_level"]["time_s"]
