"""Starting views from Python (``placement.view``) and the CLI: a scene with its plan, or a map."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from placement.errors import MapError, ViewerError
from placement.planning.methods import DEFAULT_METHOD
from placement.viewer.server import View, start_server

if TYPE_CHECKING:
    from placement.scene import Scene

SCENE_SUFFIXES = (".yaml", ".yml")


def view_scene(
    scene: Scene | Path | str,
    maps: Path | str | None = None,
    method: str = DEFAULT_METHOD,
    plan: Path | str | None = None,
    port: int = 0,
) -> View:
    """Serve a 3D view of ``scene`` (a Scene or scene file) and its plan on 127.0.0.1:``port``.

    The plan is made with ``method`` over ``maps`` (cost maps shown), or read from the plan file
    ``plan`` (JSON of ``placement query --json``; no cost maps, no maps needed). Returns the running
    :class:`View`; ``view.content`` is the :class:`PlanView` and ``view.planner`` the planner (None
    with ``plan``). ``view.timings`` holds ``load_s`` (scene, robot and maps opened), ``first_step_s``
    (planned and drawn after loading) [s].
    """
    from placement.planning import Planner
    from placement.robots import load_robot
    from placement.scene import Scene, load_scene
    from placement.viewer.plan_file import load_plan
    from placement.viewer.plan_view import PlanView
    from placement.viewer.scene_view import draw_scene

    t0 = time.perf_counter()
    planner = None
    if plan is not None:
        scene = scene if isinstance(scene, Scene) else load_scene(scene)
        robot, world = load_robot(scene.robot_preset), None
        steps = load_plan(plan, robot)
    else:
        planner = Planner(scene, method, maps)
        scene, robot, world = planner.scene, planner.robot, planner.world
    t1 = time.perf_counter()
    server = start_server(port, label=f"placement: {scene.name}")
    try:
        if planner is not None:
            steps = planner.plan(keep_maps=True).steps
        server.initial_camera.look_at = (
            (scene.bounds[0] + scene.bounds[2]) / 2,
            (scene.bounds[1] + scene.bounds[3]) / 2,
            0.0,
        )
        server.initial_camera.position = (scene.bounds[0] - 1.0, scene.bounds[1] - 2.5, 6.0)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        draw_scene(server, scene, robot.footprint_radius, robot.footprint)
        title = f"{scene.name}: " + (f"{method} plan" if plan is None else f"plan {Path(plan).name}")
        content = PlanView(server, robot, world, steps, title, start=scene.start)
    except BaseException:
        server.stop()
        raise
    return View(server, content, planner, {"load_s": t1 - t0, "first_step_s": time.perf_counter() - t1})


def view_map(
    path: Path | str, arm: str | None = None, direction: str = "best", port: int = 0, max_points: int | None = None
) -> View:
    """Serve a 3D view of the reachability map at ``path`` for ``arm`` (default: the first mapped arm)
    on 127.0.0.1:``port``: reached cells as points coloured by value (best over orientations, or for
    the TCP ``direction``), a threshold slider, the robot at home. ``view.timings["render_s"]``: from
    opening the map to the cloud sent [s]."""
    from placement.maps.opening import open_map
    from placement.maps.rmap import check_root
    from placement.robots import load_robot
    from placement.storage import open_store
    from placement.viewer.map_view import DEFAULT_POINTS, DIRECTIONS, MapView

    if direction not in DIRECTIONS:
        raise ViewerError(f"--direction: '{direction}' is not one of {', '.join(DIRECTIONS)}")
    t0 = time.perf_counter()
    store = open_store(Path(path))
    try:
        check_root(Path(path), store.root)
        preset, arms = store.root.get("preset") or store.root.get("robot"), list(store.root.get("arms") or [])
    finally:
        store.close()
    if not isinstance(preset, str):  # load_robot(None) would fail with no word of the map
        raise MapError(f"{path}: the map names no robot (no 'preset' or 'robot' in its metadata)")
    robot = load_robot(preset)
    arm = arm or next((a for a in robot.arms if a in arms), arms[0] if arms else "?")
    rmap = open_map(path, arm, robot)
    server = start_server(port, label=f"placement: map {Path(path).name} ({arm})")
    try:
        server.initial_camera.position = (2.2, -2.2, 2.0)
        server.initial_camera.look_at = (0.3, 0.0, 0.8)
        server.initial_camera.up = (0.0, 0.0, 1.0)
        content = MapView(server, rmap, robot, direction, max_points or DEFAULT_POINTS)
    except BaseException:
        server.stop()
        raise
    return View(server, content, timings={"render_s": time.perf_counter() - t0})


def view(target: Scene | Path | str, **options: Any) -> View:
    """``placement.view(...)``: a scene file or Scene (options of :func:`view_scene`) or a map
    directory or HDF5 file (options of :func:`view_map`). The view keeps serving in a background
    thread; ``view.wait()`` blocks until Ctrl-C, ``view.stop()`` ends it."""
    from placement.scene import Scene

    if isinstance(target, Scene) or str(target).endswith(SCENE_SUFFIXES):
        return view_scene(target, **options)
    return view_map(target, **options)
