"""`placement query SCENE`: best base placements for every step of a scene's task."""

from __future__ import annotations

import sys

import click

from ..planning import METHODS, Planner
from ..warmup import QUERY_COMPILE_S, announce_compilation
from .params import OneLineCommand
from .options import emit, setup_logging, standard_options, to_json_line, writable_dir


@click.command(cls=OneLineCommand, context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("scene", type=click.Path())
@click.option("--maps", "maps_path", default=None, type=click.Path(), help="Reachability maps (default: the scene's `maps`).")
@click.option("--method", type=click.Choice(METHODS), default="sequential", show_default=True)
@click.option("--plot", "plot_dir", default=None, type=click.Path(), help="Write PNG cost maps of each step here.")
@click.option("--stream", is_flag=True,
              help="After the first plan, read scene updates as JSON lines on stdin and print a new plan "
                   "(one JSON line) after each.")
@standard_options
def query(scene, maps_path, method, plot_dir, stream, as_json, verbose, quiet):
    """Plan the base placement, arm, grasp and IK solution of every step."""
    setup_logging(verbose, quiet)
    if plot_dir:
        writable_dir(plot_dir, "--plot")
    announce_compilation(QUERY_COMPILE_S)
    planner = Planner(scene, method, maps_path)
    if stream:
        stream_plans(planner)
        return
    result = planner.plan(keep_maps=plot_dir is not None)
    if plot_dir:
        from ..plotting import plot_steps

        plot_steps(planner.world, result, plot_dir, planner.scene.start, planner.robot.footprint_radius)
    emit(result.to_json(), as_json, _table)
    bad = result.failed_step
    if bad is not None:
        click.echo(f"error: step {bad.step} ({bad.action} {bad.target}) is infeasible: {bad.reason}", err=True)
        sys.exit(3)


def main() -> None:
    """The ``placement-query`` console script: the same command as ``placement query``."""
    query(prog_name="placement-query")


def _table(r: dict) -> str:
    lines = [f"scene {r['scene']}  method {r['method']}  robot {r['robot']['name']}",
             f"{'step':>4} {'action':<6} {'target':<12} {'arm':<6} {'grasp':<14} {'x [m]':>7} {'y [m]':>7} "
             f"{'yaw [rad]':>9} {'manip':>7} {'cost':>7} {'travel [s]':>10} {'ms':>7}"]
    for s in r["steps"]:
        if s.get("status") == "infeasible":
            lines.append(f"{s['step']:>4} {s['action']:<6} {s['target']:<12} infeasible: {s['reason']}")
            continue
        x, y, yaw = s["base"]
        lines.append(f"{s['step']:>4} {s['action']:<6} {s['target']:<12} {s['arm']:<6} {s['grasp']:<14} "
                     f"{x:7.3f} {y:7.3f} {yaw:9.3f} {s['manipulability']:7.4f} {s['cost']['total']:7.3f} "
                     f"{s['travel_time_s']:10.2f} {s['timings_ms']['total']:7.1f}")
    return "\n".join(lines)


def stream_plans(planner, keep_maps: bool = False, on_result=None) -> None:
    """JSON lines: the first plan, then one plan per update line read from stdin; each new PlanResult
    (planned with ``keep_maps``) is also passed to ``on_result`` (the viewer shows it)."""
    import json
    import time

    from ..errors import PlacementError

    click.echo(to_json_line(planner.plan().to_json()))
    for number, line in enumerate(sys.stdin, 1):
        if not line.strip():
            continue
        try:
            try:
                change = json.loads(line)
            except (ValueError, RecursionError) as exc:  # RecursionError: absurdly deep nesting
                raise PlacementError(f"line {number}: not valid JSON ({type(exc).__name__}: "
                                     f"{str(exc)[:80] or 'too deeply nested'})") from None
            info = planner.update(change)
            t = time.perf_counter()
            result = planner.plan(keep_maps=keep_maps)
            info["timings_ms"]["replan"] = (time.perf_counter() - t) * 1e3
            result.update = info
            if on_result is not None:
                on_result(result)
            click.echo(to_json_line(result.to_json()))
        except PlacementError as exc:
            msg = (str(exc).splitlines() or ["error"])[0]
            click.echo(f"error: {msg}", err=True)
            click.echo(json.dumps({"error": msg}))
        sys.stdout.flush()
