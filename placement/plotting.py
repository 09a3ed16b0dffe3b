"""PNG figures of each step's cost maps (like the paper's Fig. 2 and 3), readable at a glance: 150 dpi,
a legend for every marker, units on every colour bar, no empty panels. Never imported by algorithms."""

from __future__ import annotations

import hashlib
import re
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

    from placement.planning.results import PlanResult, StepMaps, StepResult
    from placement.planning.world import World
    from placement.scene.navgrid import NavGrid

DPI = 150
DISTANCE_CAP = 2.0  # [m] the distance panel saturates here: farther is all open floor
# (StepMaps field or "distance", panel title, colour bar label, colour map)
PANELS = (
    ("distance", "distance to obstacles", "distance [m]", "magma"),
    ("navigation", "navigation cost", "navigation cost [m]", "viridis"),
    ("manipulation", "manipulability (IRM)", "manipulability [dimensionless]", "viridis"),
    ("heuristic", "heuristic cost to the next step", "heuristic cost [m]", "cividis"),
    ("combined", "combined cost (Eq. 6 of Reister et al.)", "combined cost [dimensionless]", "viridis"),
)


def panel_data(key: str, world: World, maps: StepMaps) -> np.ma.MaskedArray | None:
    """The masked (ny, nx) layer of a panel, or None when it would be an empty panel (no layer, or
    a single value everywhere, such as the heuristic of the last step, which has no next step)."""
    layer = np.minimum(world.distance, DISTANCE_CAP) if key == "distance" else getattr(maps, key)
    if layer is None:
        return None
    data = np.ma.masked_invalid(np.asarray(layer, dtype=float))
    if key == "manipulation":
        data = np.ma.masked_less_equal(data, 0.0)
    if not data.count() or float(data.max()) == float(data.min()):
        return None
    return data


def draw_markers(
    ax: Axes,
    world: World,
    step: StepResult,
    maps: StepMaps,
    start: tuple[float, float, float] | None,
    footprint_radius: float | None,
) -> None:
    """Obstacles, the infeasible area, the path, the start, the target and the chosen placement."""
    from matplotlib.patches import Circle
    from matplotlib.patches import Polygon as PolygonPatch

    nav = world.nav
    xs, ys = nav.centres()
    blocked = np.ma.masked_where(world.feasible, np.ones(world.feasible.shape))
    ax.imshow(
        blocked,
        origin="lower",
        extent=extent_of(nav),
        cmap="Greys",
        vmin=0,
        vmax=3,
        alpha=0.55,
        interpolation="nearest",
    )
    ax.contour(xs, ys, world.occupied.astype(float), levels=[0.5], colors="k", linewidths=0.8)
    if maps.path is not None and len(maps.path):
        ax.plot(xs[maps.path[:, 1]], ys[maps.path[:, 0]], "-", color="red", lw=1.6)
    if start is not None:
        ax.plot(start[0], start[1], "o", color="white", mec="k", ms=7)
    if step.ok:
        x, y, yaw = step.base
        r = footprint_radius or 0.3
        base = getattr(world, "base", None)
        if base is not None and base.polygon is not None:  # the real outline at the chosen yaw
            ax.add_patch(PolygonPatch(base.placed(x, y, yaw), closed=True, fill=False, ec="red", lw=1.6))
            r = base.half_depth()
        else:
            ax.add_patch(Circle((x, y), r, fill=False, ec="red", lw=1.6))
        ax.annotate(
            "",
            (x + r * np.cos(yaw), y + r * np.sin(yaw)),
            (x, y),
            arrowprops={"arrowstyle": "-|>", "color": "red", "lw": 1.6},
        )
        ax.plot(step.tcp[-1][0, 3], step.tcp[-1][1, 3], "*", color="white", mec="k", ms=13)


def extent_of(nav: NavGrid) -> tuple[float, float, float, float]:
    return (
        nav.origin[0],
        nav.origin[0] + nav.shape[1] * nav.resolution,
        nav.origin[1],
        nav.origin[1] + nav.shape[0] * nav.resolution,
    )


def legend_handles(
    step: StepResult, start: tuple[float, float, float] | None, has_path: bool, outline: bool = False
) -> list[Artist]:
    """The legend's entries; ``outline``: the chosen placement is drawn as the robot's footprint polygon
    (else as its footprint circle)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    h: list[Artist] = [
        Line2D([], [], color="k", lw=0.8, label="obstacle outline"),
        Patch(color="0.55", alpha=0.55, label="infeasible for the base\n(obstacle or closer than footprint)"),
    ]
    if has_path:
        h.append(Line2D([], [], color="red", lw=1.6, label="path from the previous placement"))
    if start is not None:
        h.append(Line2D([], [], ls="", marker="o", color="white", mec="k", ms=7, label="start pose"))
    if step.ok:
        if outline:
            h.append(Patch(fill=False, ec="red", lw=1.6, label="chosen placement: footprint outline\n(arrow: heading)"))
        else:
            h.append(
                Line2D(
                    [],
                    [],
                    ls="",
                    marker="o",
                    mfc="none",
                    mec="red",
                    ms=12,
                    mew=1.6,
                    label="chosen placement: footprint circle\n(arrow: heading)",
                )
            )
        h.append(Line2D([], [], ls="", marker="*", color="white", mec="k", ms=13, label=f"target ({step.target})"))
    return h


def plot_step(
    world: World,
    step: StepResult,
    path: Path | str,
    start: tuple[float, float, float] | None = None,
    footprint_radius: float | None = None,
) -> Path | None:
    """One PNG of ``step`` (a StepResult with ``maps``) over ``world`` at ``path``; None without maps.

    ``start`` (x [m], y [m], yaw [rad]) and ``footprint_radius`` [m] add the start pose and the true
    footprint size."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    maps = step.maps
    if maps is None:
        return None
    panels = [
        (title, label, cmap, data)
        for key, title, label, cmap in PANELS
        if (data := panel_data(key, world, maps)) is not None
    ]
    cols = 3
    rows = (len(panels) + 1 + cols - 1) // cols  # one cell more for the legend
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.4 * rows), squeeze=False)
    axes = axes.ravel()
    for ax, (title, label, cmap, data) in zip(axes, panels):
        im = ax.imshow(data, origin="lower", extent=extent_of(world.nav), cmap=cmap, interpolation="nearest")
        fig.colorbar(im, ax=ax, fraction=0.046, pad=0.03).set_label(label, fontsize=10)
        draw_markers(ax, world, step, maps, start, footprint_radius)
        ax.set_title(title, fontsize=12)
        ax.set_xlabel("x [m]", fontsize=10)
        ax.set_ylabel("y [m]", fontsize=10)
        ax.set_aspect("equal")
    legend_ax = axes[len(panels)]
    legend_ax.axis("off")
    has_path = maps.path is not None and len(maps.path) > 0
    outline = getattr(getattr(world, "base", None), "polygon", None) is not None  # as draw_markers draws it
    legend_ax.legend(handles=legend_handles(step, start, has_path, outline), loc="center", fontsize=10, frameon=False)
    for ax in axes[len(panels) + 1 :]:
        ax.remove()
    dropped = [t for k, t, _, _ in PANELS if panel_data(k, world, maps) is None]
    note = f"\n(not shown, a single value everywhere: {', '.join(dropped)})" if dropped else ""
    fig.suptitle(
        f"step {step.step}: {step.action} {step.target}"
        + (f" ({step.arm} arm, {step.grasp})" if step.ok else f" (infeasible: {step.reason})")
        + note,
        fontsize=14,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return Path(path)


MAX_NAME = 80  # characters of a target in a figure's file name; longer ones are cut and get a hash


def file_name(step: StepResult) -> str:
    """``stepNN_action_target.png`` with only letters, digits, ``.``, ``_`` and ``-`` (a reach step's
    target lists its trajectories with commas: ``a,b`` becomes ``a_or_b``; other characters become ``-``)."""
    target = re.sub(r"[^A-Za-z0-9._-]+", "-", str(step.target).replace(",", "_or_")).strip(".-") or "target"
    if len(target) > MAX_NAME:
        target = f"{target[: MAX_NAME - 11]}-{hashlib.sha256(str(step.target).encode()).hexdigest()[:10]}"
    return f"step{step.step:02d}_{step.action}_{target}.png"


def plot_steps(
    world: World,
    result: PlanResult,
    out_dir: Path | str,
    start: tuple[float, float, float] | None = None,
    footprint_radius: float | None = None,
) -> list[Path]:
    """One PNG per step of ``result`` (a PlanResult planned with ``keep_maps``) over ``world`` (the
    planner's World) in ``out_dir``: distance, navigation, manipulability, heuristic and combined cost
    (panels that would be empty are left out), with the path, start, target and chosen placement."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    for step in result.steps:
        path = plot_step(world, step, out / file_name(step), start, footprint_radius)
        if path is not None:
            files.append(path)
    return files
