"""A plan in the viewer: a step slider; per step the robot at its placement in its whole configuration
(the arm's IK solution, the fixed joints such as a torso at the step's values, the other arms idle),
the TCP trajectory, the base path from the previous placement, the footprint, and the step's cost maps
as floor layers (each switchable, with its colour scale)."""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from typing import TYPE_CHECKING, cast

import numpy as np
import numpy.typing as npt

from placement.viewer.colors import Scale, layer_image, scale_of
from placement.viewer.geometry import footprint_segments, polyline_segments, ring_segments, yaw_wxyz
from placement.viewer.plan_file import title
from placement.viewer.robot_view import RobotDrawing, step_config

if TYPE_CHECKING:
    import viser

    from placement.planning.results import StepResult
    from placement.planning.world import World
    from placement.robots import Robot

PATH = (220, 40, 40)
TCP = (250, 200, 20)
FOOTPRINT = (20, 60, 200)
# (key, label, unit, colour map); distance is the world's, the others a step's StepMaps fields
LAYERS = (
    ("distance", "distance to obstacles", "m", "magma"),
    ("navigation", "navigation cost", "m", "viridis"),
    ("manipulation", "IRM manipulability", "dimensionless", "viridis"),
    ("heuristic", "heuristic cost", "m", "cividis"),
    ("combined", "combined cost (Eq. 6 of Reister et al.)", "dimensionless", "viridis"),
)
DISTANCE_CAP = 2.0  # [m] farther than this is all the same to the velocity model's look


class PlanView:
    """Draws ``steps`` (a list of :class:`~placement.planning.StepResult`) of a plan over the
    scene's ``world`` (its World, or None without maps) in ``server``; ``robot`` is the placement Robot.

    Attributes: step_ms (the last step switch's drawing time [ms]).
    """

    def __init__(
        self,
        server: viser.ViserServer,
        robot: Robot,
        world: World | None,
        steps: Iterable[StepResult],
        title: str = "plan",
        start: tuple[float, float, float] | None = None,
    ) -> None:
        self.server, self.robot, self.world, self.start = server, robot, world, start
        self.steps = list(steps)
        self.current = 0
        self.step_ms = float("nan")
        self.layer_cache: dict[tuple[int, str], tuple[npt.NDArray[np.uint8], Scale]] = {}
        self.robot_drawing = RobotDrawing(server, robot)
        gui = server.gui
        gui.add_markdown(f"**{title}**")
        self.slider = gui.add_slider("step", 0, max(len(self.steps) - 1, 1), 1, 0, disabled=len(self.steps) < 2)
        self.info = gui.add_markdown("")
        with gui.add_folder("cost layers (floor)"):
            self.toggles = {key: gui.add_checkbox(label, key == "combined") for key, label, _, _ in LAYERS}
            self.scales = gui.add_html("")
        self.slider.on_update(lambda _: self.show(int(self.slider.value)))
        for box in self.toggles.values():
            box.on_update(lambda _: self.show(self.current))
        self.images: dict[str, viser.ImageHandle] = {}
        self.labels: list[viser.LabelHandle] = []
        self.overview()
        self.show(0)

    # -- data ------------------------------------------------------------
    def layer(self, index: int, key: str) -> tuple[npt.NDArray[np.uint8], Scale] | None:
        """(RGBA image, scale) of layer ``key`` at step ``index``, or None if the step has no such layer
        or it holds a single value (an empty panel tells nothing)."""
        hit = self.layer_cache.get((index, key))
        if hit is not None:
            return hit
        spec = next(s for s in LAYERS if s[0] == key)
        if key == "distance":
            data = None if self.world is None else np.minimum(self.world.distance, DISTANCE_CAP)
        else:
            maps = self.steps[index].maps
            data = None if maps is None else getattr(maps, key)
        if data is None:
            return None
        values = np.asarray(data, dtype=float)
        valid = values > 0 if key == "manipulation" else None
        scale = scale_of(values, spec[1], spec[2], spec[3], valid)
        if not scale.hi > scale.lo:
            return None
        hit = self.layer_cache[(index, key)] = (layer_image(values, scale, valid), scale)
        return hit

    # -- drawing -----------------------------------------------------------
    def set_steps(self, steps: Iterable[StepResult]) -> None:
        """Replace the plan (a live update) and redraw the current step."""
        self.steps = list(steps)
        self.layer_cache.clear()
        self.slider.max = max(len(self.steps) - 1, 1)
        self.slider.disabled = len(self.steps) < 2
        self.overview()
        self.show(min(self.current, len(self.steps) - 1))

    def show(self, index: int) -> None:
        t = time.perf_counter()
        index = int(np.clip(index, 0, len(self.steps) - 1))
        self.current = index
        s = self.steps[index]
        with self.server.atomic():
            self.draw_layers(index)
            self.draw_placements(index)
            if s.ok:
                self.robot_drawing.show(s.base, step_config(self.robot, s))  # the step's torso included
            else:
                self.robot_drawing.visible = False
            self.info.content = self.describe(s)
            if int(self.slider.value) != index:
                # viser's value has a setter, but one of another type than its getter: mypy takes it as read-only
                self.slider.value = index  # type: ignore[misc]
        self.step_ms = (time.perf_counter() - t) * 1e3

    def describe(self, s: StepResult) -> str:
        if not s.ok:
            return f"**{title(s)}**"
        x, y, yaw = s.base
        lines = [f"**{title(s)}**", f"base x {x:.2f} m, y {y:.2f} m, yaw {np.degrees(yaw):.0f} deg"]
        # a plan file may leave these out (read as NaN)
        if math.isfinite(s.manipulability):
            lines.append(f"manipulability {s.manipulability:.4f}")
        if math.isfinite(s.cost.total):
            lines.append(f"cost {s.cost.total:.3f} (Eq. 6, dimensionless)")
        if math.isfinite(s.travel_time_s):
            lines.append(f"travel {s.travel_time_s:.1f} s")
        return "  \n".join(lines)

    def draw_layers(self, index: int) -> None:
        nav = None if self.world is None else self.world.nav
        html = []
        for z, (key, _, _, _) in enumerate(LAYERS):
            hit = self.layer(index, key) if self.toggles[key].value and nav is not None else None
            node = self.images.get(key)
            if hit is None:
                if node is not None:
                    node.visible = False
                continue
            img, scale = hit
            assert nav is not None  # a layer is drawn only with the world's grid
            html.append(scale.html())
            ny, nx = nav.shape
            w, h = nx * nav.resolution, ny * nav.resolution
            # later layers a little higher, so the one ticked last in the list is on top
            pos = (nav.origin[0] + w / 2, nav.origin[1] + h / 2, 0.004 + 0.002 * z)
            if node is None:
                self.images[key] = self.server.scene.add_image(
                    f"/layers/{key}", img, w, h, format="png", position=pos, cast_shadow=False
                )
            else:
                node.image = img
                node.visible = True
        if self.world is None:
            html.append("<i>no cost maps: the plan was read from a file</i>")
        self.scales.content = "".join(html)

    def draw_placements(self, index: int) -> None:
        """The footprint and heading at this step's base, its TCP trajectory, and the base path from
        the previous placement (the planner's grid path when kept, else a straight line)."""
        s = self.steps[index]
        scene = self.server.scene
        r = self.robot.footprint_radius
        if not s.ok:
            for name in ("footprint", "heading", "tcp", "path"):
                scene.add_frame(f"/plan/{name}", show_axes=False, visible=False)
            return
        x, y, yaw = s.base
        scene.add_line_segments(
            "/plan/footprint",
            footprint_segments(r, self.robot.footprint, 0.015),
            FOOTPRINT,
            thickness=0.025,
            position=(x, y, 0.0),
            wxyz=yaw_wxyz(yaw),
        )
        head = polyline_segments(np.array([[0, 0, 0.015], [r, 0, 0.015]]))
        scene.add_line_segments(
            "/plan/heading", head, FOOTPRINT, thickness=0.04, position=(x, y, 0.0), wxyz=yaw_wxyz(yaw)
        )
        scene.add_line_segments("/plan/tcp", polyline_segments(s.tcp[:, :3, 3]), TCP, thickness=0.012)
        path = self.base_path(index)
        scene.add_line_segments("/plan/path", polyline_segments(path), PATH, thickness=0.03)

    def overview(self) -> None:
        """Every planned placement as a thin ring with its step number, and the straight tour between them."""
        ok = [(s.step, s.base) for s in self.steps if s.ok]
        rings = [ring_segments(0.12, 0.01, 16) + np.array([*b[:2], 0.0], np.float32) for _, b in ok]
        scene = self.server.scene
        scene.add_line_segments(
            "/plan/all",
            np.concatenate(rings) if rings else np.zeros((1, 2, 3), np.float32),
            FOOTPRINT,
            thickness=0.015,
            visible=bool(rings),
        )
        corners = [self.start[:2]] if self.start is not None else []
        tour = np.array(corners + [b[:2] for _, b in ok]).reshape(-1, 2)
        if len(tour) < 2:
            tour = np.zeros((2, 2))
        scene.add_line_segments(
            "/plan/tour",
            polyline_segments(np.c_[tour, np.full(len(tour), 0.008)]),
            PATH,
            thickness=0.008,
            visible=len(ok) > 0,
        )
        for label in self.labels:
            label.remove()
        self.labels = [
            scene.add_label(f"/plan/labels/{step}", str(step), position=(b[0], b[1], 0.15)) for step, b in ok
        ]

    def base_path(self, index: int) -> npt.NDArray[np.float64]:
        """(m, 3) points [m] of the base path to step ``index`` (at z = 2 cm, above the layers)."""
        s = self.steps[index]
        assert s.ok  # drawn for planned steps only
        cells = getattr(s.maps, "path", None) if s.maps is not None else None
        if cells is not None and len(cells) and self.world is not None:
            xs, ys = self.world.nav.centres()
            pts = np.c_[xs[cells[:, 1]], ys[cells[:, 0]]]
        else:
            prev = next((p.base for p in reversed(self.steps[:index]) if p.ok), None)
            start = prev if prev is not None else self.start
            pts = np.array([start[:2], s.base[:2]]) if start is not None else np.array([s.base[:2]])
        return cast("npt.NDArray[np.float64]", np.c_[pts, np.full(len(pts), 0.02)])
