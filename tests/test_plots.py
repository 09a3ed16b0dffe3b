"""The static figures: size and resolution, a legend for every marker, units on every colour bar,
no empty panels (for example the last step's heuristic, which has no next step)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import placement
from placement.evaluation.plots import plot_task_times
from placement.plotting import DPI, PANELS, panel_data, plot_steps

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "table_clearing.yaml"


@pytest.fixture(scope="module")
def planned(maps_dir):
    planner = placement.Planner(EXAMPLE, "sequential", maps_dir)
    return planner, planner.plan(keep_maps=True)


@pytest.fixture(scope="module")
def figures(planned, tmp_path_factory):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    planner, result = planned
    made = []
    real_savefig = plt.Figure.savefig

    def keep(fig, *a, **k):  # the figures themselves, to read their artists after saving
        made.append(fig)
        return real_savefig(fig, *a, **k)

    plt.Figure.savefig = keep
    try:
        files = plot_steps(
            planner.world, result, tmp_path_factory.mktemp("plots"), planner.scene.start, planner.robot.footprint_radius
        )
    finally:
        plt.Figure.savefig = real_savefig
    return files, made


@pytest.mark.slow
def test_one_readable_png_per_step(planned, figures):
    from PIL import Image

    files, _ = figures
    assert len(files) == len(planned[1].steps) == 6
    for f in files:
        img = Image.open(f)
        assert img.width >= 1800 and img.height >= 1000
        assert round(img.info["dpi"][0]) == DPI == 150


def test_every_colour_bar_has_a_unit_and_every_marker_a_legend(figures):
    _, figs = figures
    for fig in figs:
        bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert bars and all(("[" in ax.get_ylabel() and "]" in ax.get_ylabel()) for ax in bars)
        legend = next(ax.get_legend() for ax in fig.axes if ax.get_legend() is not None)
        texts = " ".join(t.get_text() for t in legend.get_texts())
        for word in ("path", "start pose", "chosen placement", "heading", "target", "infeasible"):
            assert word in texts, word
        for ax in fig.axes:
            if ax.get_label() != "<colorbar>" and ax.get_title():
                assert ax.get_xlabel() == "x [m]" and ax.get_ylabel() == "y [m]"
                assert ax.title.get_fontsize() >= 12


def test_no_empty_panel(planned, figures):
    planner, result = planned
    _, figs = figures
    last = result.steps[-1]
    assert panel_data("heuristic", planner.world, last.maps) is None  # the last step has no next step
    titles = [ax.get_title() for ax in figs[-1].axes if ax.get_title()]
    assert not any("heuristic" in t for t in titles) and len(titles) == len(PANELS) - 1
    assert "not shown" in figs[-1]._suptitle.get_text()
    for fig in figs:
        for ax in fig.axes:
            for im in ax.get_images()[:1]:
                data = np.ma.masked_invalid(im.get_array())
                assert data.count() and data.max() > data.min()


def test_task_time_figure(tmp_path):
    from PIL import Image

    doc = {
        "scenes": ["a", "b", "c"],
        "methods": {"sequential": {"task_time_s": [10.0, 12.0, None]}, "optimal": {"task_time_s": [None, None, None]}},
    }
    path = plot_task_times(doc, tmp_path / "t.png")
    img = Image.open(path)
    assert round(img.info["dpi"][0]) == 150 and img.width >= 800
