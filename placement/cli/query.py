"""`placement query SCENE`: best base placements for every step of a scene's task."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any, BinaryIO

import click

from placement.cli import run_then_exit, spent_s
from placement.cli.options import (
    bounded,
    emit,
    maps_option,
    method_option,
    scene_argument,
    setup_logging,
    standard_options,
    to_json_line,
    writable_dir,
    writable_file,
)
from placement.cli.params import OneLineCommand

if TYPE_CHECKING:
    from placement.planning import Planner, PlanResult


@click.command(cls=OneLineCommand, context_settings={"help_option_names": ["-h", "--help"]})
@scene_argument
@maps_option
@method_option
@click.option("--plot", "plot_dir", default=None, type=click.Path(), help="Write PNG cost maps of each step here.")
@click.option(
    "--stream",
    is_flag=True,
    help="After the first plan, read scene updates as JSON lines on stdin and print a new plan "
    "(one JSON line) after each.",
)
@click.option(
    "--mcap",
    "mcap_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Also record the scene and the plan as ROS 2 messages in this MCAP file (Foxglove, ros2 bag play; "
    "needs `pip install 'placement[ros]'`).",
)
@standard_options
def query(
    scene: str,
    maps_path: str | None,
    method: str,
    plot_dir: str | None,
    stream: bool,
    mcap_path: str | None,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Plan the base placement, arm, grasp and IK solution of every step of SCENE's task.

    Prints a table (or with --json the plan document: docs/planning.md) with the plan's certificate,
    a lower bound on its travel time, and the gaps to it. A step that cannot be done gives exit 3,
    `"status": "infeasible"` and its reason. --mcap also records the scene and the plan as ROS 2
    messages. `placement-query` is the same command as its own console script."""
    began = time.perf_counter()
    setup_logging(verbose, quiet)
    from placement.compile_clock import compile_seconds
    from placement.planning import Planner
    from placement.warmup import QUERY_COMPILE_S, announce_compilation

    compiled = compile_seconds()

    if plot_dir:
        writable_dir(plot_dir, "--plot")
    if mcap_path:
        from placement.ros import require_ros

        require_ros("--mcap")
        if stream:
            raise click.UsageError("--mcap records one plan; it cannot be given with --stream")
        writable_file(mcap_path, "--mcap")
    announce_compilation(QUERY_COMPILE_S)
    planner = Planner(scene, method, maps_path)
    if stream:
        stream_plans(planner, spent=spent_s(began, compiled))
        return
    result = planner.plan(keep_maps=plot_dir is not None, spent_s=spent_s(began, compiled))
    if plot_dir:
        from placement.plotting import plot_steps

        files = plot_steps(planner.world, result, plot_dir, planner.scene.start, planner.robot.footprint_radius)
        if not quiet:
            click.echo(f"plots: {len(files)} PNG file{'' if len(files) == 1 else 's'} in {plot_dir}", err=True)
    if mcap_path:
        from pathlib import Path

        from placement.ros.recording import record_plan

        record_plan(mcap_path, Path(scene).read_text(encoding="utf-8"), result, planner)
        if not quiet:
            click.echo(f"recorded the scene and the plan in {mcap_path}", err=True)
    emit(result.to_json(), as_json, _table)
    bad = result.failed_step
    if bad is not None:
        click.echo(f"error: step {bad.step} ({bad.action} {bad.target}) is infeasible: {bad.reason}", err=True)
        sys.exit(3)


def main() -> None:
    """The ``placement-query`` console script: the same command as ``placement query``."""
    from placement.process_env import configure_process

    configure_process()
    run_then_exit(query, prog_name="placement-query")


#: (header, alignment) of the result table's columns; each is as wide as its longest entry
COLUMNS = (
    ("step", ">"),
    ("action", "<"),
    ("target", "<"),
    ("arm", "<"),
    ("grasp", "<"),
    ("x [m]", ">"),
    ("y [m]", ">"),
    ("yaw [rad]", ">"),
    ("manip", ">"),
    ("cost", ">"),
    ("travel [s]", ">"),
    ("ms", ">"),  # planning time of the step [ms]
)


def moved_joints(r: dict[str, Any]) -> list[str]:
    """The fixed joints (a torso lift) whose value differs between the plan's planned steps."""
    planned = [s for s in r["steps"] if s.get("status") != "infeasible" and s.get("configuration")]
    names = planned[0]["configuration"]["fixed_joints"] if planned else []
    return [j for j in names if len({s["joints"].get(j) for s in planned}) > 1]


def _table(r: dict[str, Any]) -> str:
    """The plan as a text table whose columns fit their longest entry (names of any length line up);
    an infeasible step's reason follows its target. A fixed joint the plan moves between steps (a
    torso lift chosen per step) gets a column after the base pose."""
    moved = moved_joints(r)
    planned_ms = [s["timings_ms"]["total"] for s in r["steps"] if s.get("status") != "infeasible"]
    # a whole-task method plans every step at once: each step carries the plan's time per placement,
    # said once under the table instead of repeated on every row
    shared = len(planned_ms) > 1 and len(set(planned_ms)) == 1
    columns = COLUMNS[:8] + tuple((f"{j} [m]", ">") for j in moved) + COLUMNS[8 : len(COLUMNS) - shared]
    rows: list[tuple[list[str], str | None]] = []
    for s in r["steps"]:
        head = [str(s["step"]), str(s["action"]), str(s["target"])]
        if s.get("status") == "infeasible":
            rows.append((head, f"infeasible: {s['reason']}"))
            continue
        x, y, yaw = s["base"]
        rows.append(
            (
                head
                + [
                    str(s["arm"]),
                    str(s["grasp"]),
                    f"{x:.3f}",
                    f"{y:.3f}",
                    f"{yaw:.3f}",
                    *(f"{s['joints'][j]:.3f}" for j in moved),
                    f"{s['manipulability']:.4f}",
                    f"{s['cost']['total']:.3f}",
                    f"{s['travel_time_s']:.2f}",
                    *([] if shared else [f"{s['timings_ms']['total']:.1f}"]),
                ],
                None,
            )
        )
    widths = [
        max([len(name)] + [len(cells[i]) for cells, _ in rows if i < len(cells)]) for i, (name, _) in enumerate(columns)
    ]

    def line(cells: list[str], reason: str | None = None) -> str:
        text = " ".join(f"{c:{a}{w}}" for c, (_, a), w in zip(cells, columns, widths))
        return (f"{text} {reason}" if reason else text).rstrip()

    lines = [
        f"scene {r['scene']}  method {r['method']}  robot {r['robot']['name']}{certificate_words(r.get('certificate'))}",
        line([n for n, _ in columns]),
    ]
    lines += [line(cells, reason) for cells, reason in rows]
    if shared:
        lines.append(
            f"planned at once: {planned_ms[0]:.1f} ms per placement (the whole plan over its steps; the certificate excluded)"
        )
    return "\n".join(lines)


def certificate_words(cert: dict[str, Any] | None) -> str:
    """``  travel 46.8 s, bound 38.5 s (+21.6 %)`` for the summary line ('' without a certificate)."""
    if not cert:
        return ""
    bound = cert.get("lower_bound_s")
    if bound is None and cert.get("stopped"):
        return f"  bound: {cert['stopped']}"
    if bound is None:
        return f"  bound: no sequence of {cert['regions']} cells reaches every step"
    travel, gap = cert.get("travel_s"), cert.get("gap")
    words = f"  bound {bound:.1f} s"
    if travel is not None:
        words = f"  travel {travel:.1f} s, bound {bound:.1f} s" + (f" (+{100 * gap:.1f} %)" if gap is not None else "")
    return words


#: Longest stream line read [bytes]; a longer one is refused unread (an update adding 10,000 obstacles
#: is about 1 MB).
MAX_LINE_BYTES = 16 * 2**20


def stream_lines(stream: BinaryIO, max_bytes: int = MAX_LINE_BYTES) -> Iterator[tuple[int, str | None, str | None]]:
    """(number, text or None, reason) of every non-blank line of the binary ``stream``: text None and
    a one-line reason for a line that is longer than ``max_bytes`` (skipped without keeping it) or is
    not UTF-8."""
    number = 0
    while True:
        raw = stream.readline(max_bytes + 1)
        if not raw:
            return
        number += 1
        if len(raw) > max_bytes and not raw.endswith(b"\n"):
            size = len(raw)
            while raw and not raw.endswith(b"\n"):  # skip the rest of the line, a bounded piece at a time
                raw = stream.readline(1 << 20)
                size += len(raw)
            yield (
                number,
                None,
                (f"line {number}: {size:,} bytes, more than the {max_bytes:,} bytes a stream line may hold"),
            )
            continue
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            yield number, None, f"line {number}: not UTF-8 text (byte {exc.start})"
            continue
        if text.strip():
            yield number, text, None


def stream_plans(
    planner: Planner,
    keep_maps: bool = False,
    on_result: Callable[[PlanResult], object] | None = None,
    stream: BinaryIO | None = None,
    spent: float | None = None,
) -> None:
    """JSON lines: the first plan (with ``spent`` [s] of its time budget spent already; default: the
    planner's construction), then one answer per update line read from ``stream`` (default
    stdin, binary), each with ``update.status`` "refused" (nothing changed; ``error``: why) or
    "applied" (``update.updated``, ``update.timings_ms``; the new plan's keys, or none and
    ``plan_error``: why planning failed; ``plan_error`` is null when it planned). Each new
    PlanResult (planned with ``keep_maps``) is also passed to ``on_result`` (the viewer shows it)."""

    from placement.errors import PlacementError
    from placement.validation import one_line, parse_json

    def say(answer: dict[str, Any]) -> None:
        click.echo(to_json_line(answer))
        sys.stdout.flush()

    def first_line(exc: BaseException, data: Any = None) -> str:
        return bounded(one_line((str(exc).splitlines() or [type(exc).__name__])[0]), data)

    say(planner.plan(spent_s=planner.construction_s if spent is None else spent).to_json())
    for number, line, reason in stream_lines(stream if stream is not None else sys.stdin.buffer):
        change = None
        try:
            if reason is not None:
                raise PlacementError(reason)
            try:
                assert line is not None  # a line without a reason was read whole
                change = parse_json(line)
            except (ValueError, RecursionError) as exc:  # RecursionError: absurdly deep nesting
                raise PlacementError(
                    f"line {number}: not valid JSON ({type(exc).__name__}: {str(exc)[:80] or 'too deeply nested'})"
                ) from None
            info = planner.update(change)  # all or nothing: on error the planner is as it was
        except PlacementError as exc:
            msg = first_line(exc, change)
            click.echo(f"error: line {number}: update refused, nothing changed: {msg}", err=True)
            say({"update": {"status": "refused", "line": number}, "error": msg})
            continue
        update = {"status": "applied", "line": number, **info}
        t = time.perf_counter()
        try:
            result = planner.plan(keep_maps=keep_maps)
            update["timings_ms"]["replan"] = (time.perf_counter() - t) * 1e3
            result.update = update
            answer = result.to_json() | {"plan_error": None}
            text = to_json_line(answer)
        except PlacementError as exc:  # e.g. the start pose is now blocked; the update stays applied
            update["timings_ms"]["replan"] = (time.perf_counter() - t) * 1e3
            msg = first_line(exc, change)
            click.echo(f"error: line {number}: update applied, but planning failed: {msg}", err=True)
            say({"update": update, "plan_error": msg})
            continue
        if on_result is not None:
            on_result(result)
        click.echo(text)
        sys.stdout.flush()
