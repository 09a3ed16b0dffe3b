"""Commands that work longer than a few seconds show progress on stderr: evaluate (a bar whose elapsed
time moves during a long scene), maps info (layers read and checked per arm), maps check (IK solves)."""

from __future__ import annotations

import io
import logging
import re
import time

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


def test_evaluate_says_what_it_runs_and_its_bar_moves_during_the_first_scene(tmp_path, maps_dir, caplog):
    from placement.cli.main import cli

    runner = CliRunner()
    made = runner.invoke(cli, ["scenes", "generate", "--seed", "3", "--count", "1", "--maps", str(maps_dir),
                               str(tmp_path / "scenes"), "-q"])
    assert made.exit_code == 0, made.output
    with caplog.at_level(logging.INFO, logger="placement"):  # the CLI's log lines (stderr outside pytest)
        out = runner.invoke(cli, ["evaluate", str(tmp_path / "scenes"), "--methods", "fixed,sequential",
                                  "--workers", "1", "--json"])
    assert out.exit_code == 0, out.stderr
    frames = _frames(out.stderr)
    assert "evaluating 1 scene with fixed, sequential (1 process)" in caplog.messages
    waiting = {f.split("[")[1][:5] for f in frames if f.startswith("scenes:   0%")}
    assert len(waiting) >= 2, frames  # 00:00, 00:01, ...: the clock moved before the scene was done
    assert any(f.startswith("scenes: 100%") for f in frames)
