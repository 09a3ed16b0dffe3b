"""Figures of an evaluation document (SPEC section 8). Never imported by algorithms."""

from __future__ import annotations

from pathlib import Path


def plot_task_times(doc: dict, path) -> Path:
    """Box plot of task times per method (successful scenes), like the paper's Fig. 10 / 11."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(doc["methods"])
    data = [[t for t in doc["methods"][m]["task_time_s"] if t is not None] for m in methods]
    fig, ax = plt.subplots(figsize=(1.6 * len(methods) + 2, 4))
    ax.boxplot(data, showmeans=True)
    ax.set_xticks(range(1, len(methods) + 1), [f"{m}\n({len(d)}/{len(doc['scenes'])} ok)" for m, d in zip(methods, data)])
    ax.set_ylabel("task time [s]")
    ax.set_title(f"Task time over {len(doc['scenes'])} scenes")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return Path(path)
