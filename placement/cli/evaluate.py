"""`placement evaluate SCENE_OR_DIR...`: methods against each other on many scenes."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import click
from click.core import ParameterSource
from tqdm import tqdm

from placement.cli.options import emit, maps_option, setup_logging, standard_options
from placement.cli.params import Bounded, OneLineCommand
from placement.errors import PlacementError
from placement.evaluation.evaluate import MAX_WORKERS, check_methods, check_scenes, summary_rows
from placement.evaluation.evaluate import evaluate as run_evaluation
from placement.evaluation.outdir import atomic_path, output_dir, write_text_atomic
from placement.planning.planner import METHODS
from placement.progress import Ticking

log = logging.getLogger("placement")


class MethodList(click.ParamType[list[str], Any]):
    """Comma-separated method names: none empty, none repeated, each one of METHODS."""

    name = "methods"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> list[str]:
        if isinstance(value, list):
            return value
        try:
            return check_methods(m.strip() for m in str(value).split(","))
        except PlacementError as exc:
            self.fail(str(exc), param, ctx)


@click.command(cls=OneLineCommand)
@click.argument("scenes", nargs=-1, required=True, type=click.Path(exists=True))
@click.option(
    "--methods",
    type=MethodList(),
    default=",".join(METHODS),
    show_default=True,
    help="Comma-separated methods, each at most once.",
)
@maps_option
@click.option(
    "--out",
    "out_dir",
    default=None,
    type=click.Path(),
    help="Write table (md, csv), JSON and box plot here (created and checked before the evaluation).",
)
@click.option(
    "--workers",
    type=Bounded(1, MAX_WORKERS),
    default=2,
    show_default=True,
    help=f"Scenes evaluated in parallel, 1 to {MAX_WORKERS}.",
)
@click.option(
    "--dask",
    "dask_address",
    default=None,
    metavar="ADDRESS",
    help="Spread the scenes over a Dask cluster (scheduler address, e.g. tcp://host:8786) instead of "
    "local processes; its workers must see the scene and map files at the same paths.",
)
@standard_options
def evaluate(
    scenes: tuple[str, ...],
    methods: list[str],
    maps_path: str | None,
    out_dir: str | None,
    workers: int,
    dask_address: str | None,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Plan every scene (files, or folders of them) with each method and compare task times.

    Task times, success and paired reductions (docs/evaluation.md); --out writes summary.md,
    summary.csv, results.json and task_times.png; --dask spreads the scenes over a Dask cluster (the
    same document)."""
    setup_logging(verbose, quiet)
    if dask_address and click.get_current_context().get_parameter_source("workers") != ParameterSource.DEFAULT:
        raise PlacementError("--workers and --dask exclude each other: the cluster's workers run the scenes")
    files = check_scenes(scenes)
    bars: list[tqdm[NoReturn]] = []

    def progress(done: int, total: int) -> None:
        if not bars:  # created once the scenes are checked, so that an early error stays one line
            bars.append(tqdm(total=total, desc="scenes", unit="scene", disable=quiet, leave=False))
            ticking.enter_context(Ticking(bars[0]))  # the elapsed time moves during a long first scene
        bars[0].n = done
        bars[0].refresh()

    log.info(
        "evaluating %d scene%s with %s (%s)",
        len(files),
        "" if len(files) == 1 else "s",
        ", ".join(methods),
        "on the Dask cluster"
        if dask_address
        else f"{min(workers, len(files))} process" + ("" if min(workers, len(files)) == 1 else "es"),
    )
    with contextlib.ExitStack() as stack, contextlib.ExitStack() as ticking:
        if out_dir:
            stack.enter_context(output_dir(out_dir, "--out"))
        client = None
        if dask_address:
            from placement.cli.maps_build import dask_client  # with the build spec and the stores: for --dask only

            client = dask_client(dask_address)
            stack.callback(client.close)
        try:
            doc = run_evaluation(files, methods, maps_path, workers=workers, progress=progress, client=client)
        finally:
            ticking.close()
            for bar in bars:
                bar.close()
        if out_dir:
            write_report(doc, Path(out_dir))
    emit(doc, as_json, lambda d: markdown_table(summary_rows(d)))


def markdown_table(rows: list[dict[str, Any]]) -> str:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    fmt: Callable[[Any], str] = lambda v: "-" if v is None else (f"{v:.3g}" if isinstance(v, float) else str(v))  # noqa: E731
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def write_report(doc: dict[str, Any], out: Path) -> None:
    """``results.json``, ``summary.md``, ``summary.csv`` and ``task_times.png`` in ``out``."""
    from placement.evaluation.plots import plot_task_times

    rows = summary_rows(doc)
    # each file whole or not at all: a run stopped while writing leaves no half table for a reader
    write_text_atomic(out / "results.json", json.dumps(doc, indent=1))
    write_text_atomic(out / "summary.md", markdown_table(rows) + "\n")
    table = io.StringIO()
    w = csv.DictWriter(table, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
    w.writeheader()
    w.writerows(rows)
    write_text_atomic(out / "summary.csv", table.getvalue(), newline="")
    with atomic_path(out / "task_times.png") as tmp:
        plot_task_times(doc, tmp)
