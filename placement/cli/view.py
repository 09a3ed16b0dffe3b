"""`placement view SCENE` and `placement maps view MAP`: interactive 3D views in the browser (viser)."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, cast

import click

from placement.cli.options import (
    F,
    map_argument,
    maps_option,
    scene_argument,
    setup_logging,
    standard_options,
    to_json_line,
)
from placement.cli.params import Bounded, OneLineCommand, OneLineError
from placement.method_names import DEFAULT_METHOD
from placement.method_names import METHOD_NAMES as METHODS

if TYPE_CHECKING:
    from placement.scene import Scene
    from placement.viewer.plan_view import PlanView
    from placement.viewer.server import View

PORT = Bounded(0, 65535)


def port_option(f: F) -> F:
    return click.option(
        "--port",
        type=PORT,
        default=8080,
        show_default=True,
        help="Port on 127.0.0.1 (0: any free one; a busy port: the next free one).",
    )(f)


def serve(view: View, as_json: bool, what: str, timeout: float | None = None) -> None:
    """Print where the view is, then serve it until Ctrl-C (or ``timeout`` [s])."""
    info = {"url": view.url, "timings_s": {k: round(v, 3) for k, v in view.timings.items()}}
    try:
        # a Ctrl-C as soon as the line is out (a loaded machine may not have reached the wait yet) stops
        # the server as one in the wait does
        click.echo(to_json_line(info) if as_json else f"{what} at {view.url} (Ctrl-C to stop)", err=not as_json)
        sys.stdout.flush()
        view.wait(timeout)
    except KeyboardInterrupt:
        pass
    finally:
        view.stop()


@click.command(cls=OneLineCommand, context_settings={"help_option_names": ["-h", "--help"]})
@scene_argument
@maps_option
@click.option("--method", type=click.Choice(METHODS), default=None, help=f"Planning method (default {DEFAULT_METHOD}).")
@click.option(
    "--plan",
    "plan_path",
    default=None,
    type=click.Path(),
    help="Show this plan (JSON of `placement query --json`) instead of planning; no maps needed.",
)
@click.option(
    "--stream",
    is_flag=True,
    help="Read scene updates as JSON lines on stdin (as `placement query --stream`), show each new "
    "plan live and print it as one JSON line.",
)
@port_option
@click.option("--timeout", type=float, default=None, hidden=True, help="Stop after this many seconds (tests).")
@standard_options
def view(
    scene: str,
    maps_path: str | None,
    method: str | None,
    plan_path: str | None,
    stream: bool,
    port: int,
    timeout: float | None,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Serve a 3D view of a scene and its plan on 127.0.0.1: robot, TCP paths, base paths, cost maps.

    Plans SCENE (--method), or shows a plan file (--plan, checked against the scene); prints the URL
    and serves until Ctrl-C."""
    setup_logging(verbose, quiet)
    if plan_path and (method or stream or maps_path):
        given = [o for o, v in (("--method", method), ("--stream", stream), ("--maps", maps_path)) if v]
        raise OneLineError(f"--plan shows a plan file; it cannot be combined with {', '.join(given)}")
    from placement.viewer import view_scene

    target: Scene | str = scene
    if plan_path:  # a plan made for another scene or robot is refused before anything is served
        from placement.scene import load_scene
        from placement.viewer.plan_file import load_checked_plan

        shown = target = load_scene(scene)
        load_checked_plan(plan_path, shown)
    v = view_scene(target, maps=maps_path, method=method or DEFAULT_METHOD, plan=plan_path, port=port)
    if stream:
        from placement.cli.query import stream_plans

        click.echo(f"viewer at {v.url}; reading updates from stdin", err=True)
        try:
            # as `placement query --stream`, and each new plan is shown
            planner, content = v.planner, cast("PlanView", v.content)
            assert planner is not None  # a scene view without --plan plans
            stream_plans(planner, keep_maps=True, on_result=lambda result: content.set_steps(result.steps))
        except BaseException:
            v.stop()
            raise
    serve(v, as_json and not stream, "viewer", timeout)


@click.command("view", cls=OneLineCommand, context_settings={"help_option_names": ["-h", "--help"]})
@map_argument
@click.option("--arm", default=None, metavar="ARM", help="Arm to show (default: the first mapped arm).")
@click.option(
    "--direction",
    default="best",
    show_default=True,
    type=click.Choice(["best", "down", "up", "forward", "backward", "left", "right"]),
    help="Colour by the best value over all orientations, or for this TCP approach direction.",
)
@click.option(
    "--max-points",
    type=Bounded(1000, 5_000_000),
    default=200_000,
    show_default=True,
    help="Reached cells drawn at most (a uniform sample beyond).",
)
@port_option
@click.option("--timeout", type=float, default=None, hidden=True, help="Stop after this many seconds (tests).")
@standard_options
def maps_view(
    path: str,
    arm: str | None,
    direction: str,
    max_points: int,
    port: int,
    timeout: float | None,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Serve a 3D view of a reachability map: reached cells coloured by value, the robot at home.

    A threshold and a section slider; --direction picks the TCP direction shown."""
    setup_logging(verbose, quiet)
    from placement.viewer import view_map

    serve(
        view_map(path, arm=arm, direction=direction, port=port, max_points=max_points), as_json, "map viewer", timeout
    )
