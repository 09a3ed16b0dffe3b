"""`placement evaluate SCENE_OR_DIR...`: methods against each other on many scenes."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import click
from tqdm import tqdm

from ..planning.evaluate import evaluate as run_evaluation
from ..planning.evaluate import summary_rows
from ..planning.planner import METHODS
from .options import emit, json_option, one_line_errors, setup_logging, verbosity


@click.command()
@click.argument("scenes", nargs=-1, required=True, type=click.Path())
@click.option("--methods", default=",".join(METHODS), show_default=True, help="Comma-separated methods.")
@click.option("--maps", "maps_path", default=None, type=click.Path(), help="Reachability maps (default: each scene's).")
@click.option("--out", "out_dir", default=None, type=click.Path(), help="Write table (md, csv), JSON and box plot here.")
@click.option("--workers", type=int, default=2, show_default=True, help="Scenes evaluated in parallel.")
@json_option
@verbosity
@one_line_errors
def evaluate(scenes, methods, maps_path, out_dir, workers, as_json, verbose, quiet):
    """Plan every scene with each method and compare task times (SPEC section 8)."""
    setup_logging(verbose, quiet)
    methods = [m.strip() for m in methods.split(",") if m.strip()]
    with tqdm(desc="scenes", unit="scene", disable=quiet, leave=False) as bar:
        def progress(done, total):
            bar.total = total
            bar.n = done
            bar.refresh()

        doc = run_evaluation(scenes, methods, maps_path, workers=workers, progress=progress)
    if out_dir:
        write_report(doc, Path(out_dir))
    emit(doc, as_json, lambda d: markdown_table(summary_rows(d)))


def markdown_table(rows: list[dict]) -> str:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    fmt = lambda v: "-" if v is None else (f"{v:.3g}" if isinstance(v, float) else str(v))  # noqa: E731
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(fmt(r.get(k)) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def write_report(doc: dict, out: Path) -> None:
    from ..plotting import plot_task_times

    out.mkdir(parents=True, exist_ok=True)
    rows = summary_rows(doc)
    (out / "results.json").write_text(json.dumps(doc, indent=1))
    (out / "summary.md").write_text(markdown_table(rows) + "\n")
    with open(out / "summary.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        w.writeheader()
        w.writerows(rows)
    plot_task_times(doc, out / "task_times.png")
