"""Figures of an evaluation document (docs/evaluation.md), readable at a glance (150 dpi, labelled, with a
legend). Never imported by algorithms."""

from __future__ import annotations

from pathlib import Path
from typing import Any

DPI = 150


def plot_task_times(doc: dict[str, Any], path: Path | str) -> Path:
    """Box plot of task times per method (successful scenes), like the paper's Fig. 10 / 11.

    A method with no successful scene gets a labelled empty slot rather than a box."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    methods = list(doc["methods"])
    data = [[t for t in doc["methods"][m]["task_time_s"] if t is not None] for m in methods]
    fig, ax = plt.subplots(figsize=(1.8 * len(methods) + 3, 5))
    filled = [i for i, d in enumerate(data) if d]
    if filled:
        ax.boxplot(
            [data[i] for i in filled],
            positions=[i + 1 for i in filled],
            showmeans=True,
            meanprops={"marker": "^", "markerfacecolor": "green", "markeredgecolor": "green"},
        )
    for i, d in enumerate(data):
        if not d:
            ax.text(i + 1, 0.5, "no successful\nscene", ha="center", va="center", transform=ax.get_xaxis_transform())
    ax.set_xlim(0.5, len(methods) + 0.5)
    ax.set_xticks(
        range(1, len(methods) + 1),
        [f"{m}\n({len(d)}/{len(doc['scenes'])} ok)" for m, d in zip(methods, data)],
        fontsize=10,
    )
    ax.set_ylabel("task time [s]", fontsize=11)
    ax.set_title(f"Task time over {len(doc['scenes'])} scenes (successful ones)", fontsize=13)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(
        handles=[
            Line2D([], [], color="tab:orange", label="median"),
            Line2D([], [], ls="", marker="^", color="green", label="mean"),
            Line2D([], [], ls="", marker="o", mfc="none", mec="k", label="outlier (beyond 1.5 IQR)"),
        ],
        fontsize=9,
        loc="best",
    )
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return Path(path)
