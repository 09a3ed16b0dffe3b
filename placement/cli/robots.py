"""`placement robots init | check`: onboard a robot from its URDF and see what it reaches."""

from __future__ import annotations

import os
import shlex
import tempfile
from pathlib import Path

import click

from placement.cli.options import emit, log, setup_logging, standard_options, writable_dir
from placement.cli.params import OneLineCommand, OneLineGroup
from placement.errors import PlacementError


@click.group(cls=OneLineGroup)
def robots() -> None:
    """Robot presets: propose one from a URDF, check one."""


def check_out(path: Path, force: bool) -> None:
    """Refuse an ``--out`` that exists (without ``force``), is a directory or has no folder, before any work."""
    if path.is_dir():
        raise PlacementError(f"--out {path}: is a directory; give a .yaml file name")
    if path.exists() and not force:
        raise PlacementError(f"--out {path}: exists; give --force to overwrite it")
    if not path.resolve().parent.is_dir():
        raise PlacementError(f"--out {path}: folder {path.parent} does not exist")


def write_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder (never half a file)."""
    try:
        fd, tmp = tempfile.mkstemp(dir=path.resolve().parent, prefix=f".{path.name}.", suffix=".tmp")
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except OSError as exc:
        raise PlacementError(f"--out {path}: cannot write ({exc.strerror or exc})") from None


@robots.command(cls=OneLineCommand)
@click.argument("urdf", type=click.Path())
@click.option("--out", default=None, type=click.Path(), help="Write the preset YAML here (default: stdout).")
@click.option("--force", is_flag=True, help="Overwrite --out if it exists.")
@standard_options
def init(urdf: str, out: str | None, force: bool, as_json: bool, verbose: int, quiet: bool) -> None:
    """Propose a commented preset for the robot in URDF (a .urdf or .xacro file).

    On stdout, or written atomically to --out, never over an existing file without --force."""
    setup_logging(verbose, quiet)
    from placement.robots.onboarding.propose import propose
    from placement.robots.onboarding.render import build_command, render

    out_path = Path(out) if out else None
    if out_path is not None:
        check_out(out_path, force)
    proposal = propose(urdf, out_path)
    command = "placement robots init " + shlex.quote(str(urdf)) + (f" --out {shlex.quote(str(out))}" if out else "")
    text = render(proposal, command, shlex.quote(str(out_path)) if out_path else "PRESET.yaml")
    if out_path is not None:
        write_atomic(out_path, text)
    for w in proposal.warnings:
        log.warning("warning: %s", w)
    if as_json:
        build = build_command(shlex.quote(str(out_path)) if out_path else "PRESET.yaml", proposal.name)
        emit(
            {**proposal.to_json(), "out": str(out_path) if out_path else None, "yaml": text, "build": build}, True, str
        )
    elif out_path is None:
        click.echo(text, nl=False)
    else:
        click.echo(
            f"{out_path}: preset for {proposal.name} with arms {', '.join(a.name for a in proposal.arms)} "
            f"({proposal.seconds:.1f} s); check it with: placement robots check {out_path}; build its maps with: "
            f"{build_command(shlex.quote(str(out_path)), proposal.name)}"
        )


@robots.command(cls=OneLineCommand)
@click.argument("preset")
@click.option(
    "--plot",
    "plot_dir",
    default=None,
    type=click.Path(),
    help="Write a side view with the reach bands and a TCP close-up per arm (PNG) here.",
)
@standard_options
def check(preset: str, plot_dir: str | None, as_json: bool, verbose: int, quiet: bool) -> None:
    """Load PRESET and show the heights and distances each arm reaches top-down and horizontally.

    Warnings in plain words; --plot draws a side view with the bands and a TCP close-up per arm."""
    setup_logging(verbose, quiet)
    from placement.robots import load_robot
    from placement.robots.onboarding.check import check_robot, render_table

    if plot_dir:
        writable_dir(plot_dir, "--plot")
    robot = load_robot(preset)
    doc = check_robot(robot)
    if plot_dir:
        from placement.robots.onboarding.check_plot import plot_check

        doc["plots"] = plot_check(robot, doc, Path(plot_dir))
    emit(doc, as_json, render_table)
