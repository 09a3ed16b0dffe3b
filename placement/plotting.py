"""PNG figures of each step's cost maps (like the paper's Fig. 2 and 3). Never imported by algorithms."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_steps(world, result, out_dir) -> list[Path]:
    """One PNG per step of ``result`` (a PlanResult planned with ``keep_maps``) over ``world``
    (the planner's World): distance, navigation, manipulation, heuristic and combined cost, with
    the chosen placement (arrow) and the path from the previous placement."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    nav = world.nav
    extent = (nav.origin[0], nav.origin[0] + nav.shape[1] * nav.resolution,
              nav.origin[1], nav.origin[1] + nav.shape[0] * nav.resolution)
    xs, ys = nav.centres()
    files = []
    for step in result.steps:
        maps = step.maps
        if maps is None:
            continue
        layers = [("distance to obstacles [m]", np.minimum(world.distance, 2.0)),
                  ("navigation cost [m]", maps.navigation),
                  ("manipulability (IRM)", maps.manipulation),
                  ("heuristic cost [m]", maps.heuristic),
                  ("combined cost (Eq. 6)", maps.combined)]
        fig, axes = plt.subplots(1, 5, figsize=(22, 4.6))
        for ax, (title, layer) in zip(axes, layers):
            data = np.ma.masked_invalid(np.asarray(layer, dtype=float)) if layer is not None else None
            if data is not None and data.count():
                if title.startswith("manip"):
                    data = np.ma.masked_less_equal(data, 0.0)
                im = ax.imshow(data, origin="lower", extent=extent, cmap="viridis")
                fig.colorbar(im, ax=ax, fraction=0.046)
            ax.contour(xs, ys, world.occupied.astype(float), levels=[0.5], colors="k", linewidths=0.6)
            if step.ok:
                x, y, yaw = step.base
                ax.arrow(x, y, 0.4 * np.cos(yaw), 0.4 * np.sin(yaw), color="red", width=0.04)
                ax.plot(step.tcp[-1][0, 3], step.tcp[-1][1, 3], "w*", ms=9, mec="k")
            if maps.path is not None and len(maps.path):
                ax.plot(xs[maps.path[:, 1]], ys[maps.path[:, 0]], "r-", lw=1)
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("x [m]")
        axes[0].set_ylabel("y [m]")
        fig.suptitle(f"step {step.step}: {step.action} {step.target}"
                     + (f" ({step.arm} arm, {step.grasp})" if step.ok else " (infeasible)"))
        fig.tight_layout()
        path = out / f"step{step.step:02d}_{step.action}_{step.target}.png"
        fig.savefig(path, dpi=80)
        plt.close(fig)
        files.append(path)
    return files
