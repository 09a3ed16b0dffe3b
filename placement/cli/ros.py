"""`placement ros serve`: the planner as a ROS 2 node on standard messages."""

from __future__ import annotations

import click

from placement.cli.options import maps_option, method_option, one_line_errors, setup_logging, verbosity, writable_file
from placement.cli.params import OneLineCommand, OneLineGroup


@click.group(cls=OneLineGroup)
def ros() -> None:
    """ROS 2: the planner as a node (needs `pip install 'placement[ros]'`)."""


@ros.command(cls=OneLineCommand, context_settings={"help_option_names": ["-h", "--help"]})
@click.argument("scene", required=False, type=click.Path(exists=True, dir_okay=False))
@maps_option
@click.option("--robot", default=None, help="Robot preset every scene is planned for (default: each scene's own).")
@method_option
@click.option("--namespace", default="", help="Namespace of the node (topics /NAMESPACE/placement/...).")
@click.option(
    "--frame", default="map", show_default=True, help="The map frame until a /map message names its own frame_id."
)
@click.option(
    "--unknown",
    type=click.Choice(["occupied", "free", "cost"]),
    default="occupied",
    show_default=True,
    help="What /map's unknown cells (-1) are for the base, unless the scene's occupancy_map says "
    "(cost: open at --unknown-cost times a free cell's travel cost).",
)
@click.option(
    "--unknown-cost",
    type=click.FloatRange(1.0, 1000.0),
    default=3.0,
    show_default=True,
    help="Travel cost multiplier of an unknown /map cell under --unknown cost.",
)
@click.option(
    "--occupied-percent",
    type=click.IntRange(1, 100),
    default=65,
    show_default=True,
    help="/map cells at or above this value [%] are occupied (map_server's occupied_thresh 0.65).",
)
@click.option(
    "--record",
    default=None,
    type=click.Path(dir_okay=False),
    help="Record every scene, map and plan to this MCAP file (written when the node stops).",
)
@click.option(
    "--amcl/--no-amcl",
    default=True,
    show_default=True,
    help="Take the start from /amcl_pose (each pose AMCL publishes re-plans from there).",
)
@verbosity
@one_line_errors
def serve(
    scene: str | None,
    maps_path: str | None,
    robot: str | None,
    method: str,
    namespace: str,
    frame: str,
    unknown: str,
    unknown_cost: float,
    occupied_percent: int,
    record: str | None,
    amcl: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Run the ROS 2 node `placement` around one live planner.

    \b
    in   /map            nav_msgs/OccupancyGrid    reliable, transient local, 1
         ~/scene         std_msgs/String           reliable, volatile, 10 (a scene file's text)
         ~/objects/NAME  geometry_msgs/PoseStamped reliable, volatile, 10
         ~/start         geometry_msgs/PoseStamped reliable, volatile, 10
         /amcl_pose      geometry_msgs/PoseWithCovarianceStamped  reliable, volatile, 10
         ~/reach_goal    geometry_msgs/PoseStamped reliable, volatile, 10 (a TCP pose)
    out  ~/plan          std_msgs/String           reliable, transient local, 1 (query --json's document)
         ~/base_poses    nav_msgs/Path             reliable, transient local, 1 (for NavigateThroughPoses)
         ~/markers       visualization_msgs/MarkerArray  reliable, transient local, 1
         ~/status        std_msgs/String           reliable, volatile, 100 (one JSON line per event)
         ~/reach_base    geometry_msgs/PoseStamped reliable, volatile, 10
    srv  ~/plan_now      std_srvs/Trigger

    Every pose is in the map frame (the frame_id of /map, else --frame); a message in another frame
    is refused on ~/status, as are NaN poses, malformed or huge grids, scenes that do not parse and
    unknown objects: nothing changes and the node goes on. Messages that arrive while it plans are
    coalesced (the newest wins). Ctrl-C or SIGTERM stops it. The docs' "ROS 2" page tells how to
    wire it to Nav2 and RViz.
    """
    setup_logging(verbose, quiet)
    from pathlib import Path

    from placement.ros import require_ros

    require_ros("placement ros serve")
    from placement.ros.live import LivePlanner, MapPolicy
    from placement.ros.node import NodeOptions
    from placement.ros.node import serve as run
    from placement.scene import load_scene
    from placement.warmup import QUERY_COMPILE_S, announce_compilation

    if record is not None:
        writable_file(record, "--record")
    announce_compilation(QUERY_COMPILE_S)
    policy = MapPolicy(unknown, occupied_percent, unknown_cost)
    live = LivePlanner(maps_path, method, robot, Path(scene).parent if scene else Path.cwd(), policy)
    if scene is not None:
        outcome = live.set_scene(load_scene(scene), scene)
        if not outcome.applied:
            from placement.errors import PlacementError

            raise PlacementError(outcome.error or "the scene was refused")
    options = NodeOptions(namespace, frame, Path(record) if record else None, amcl)

    def ready(name: str) -> None:
        if not quiet:
            click.echo(f"node {name} ready (Ctrl-C stops it)", err=True)

    run(live, options, ready)
