"""Labels and figures read right: a label sits on its object, the map view's colour scale starts at the
threshold, the legend names the footprint drawn, figure file names are plain and bounded, the result
table's columns fit long names, and --plot says where it wrote."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner
from support.steps import placed_step

import placement
from placement.plotting import MAX_NAME, file_name, legend_handles
from placement.viewer.geometry import label_offset

ROOT = Path(__file__).resolve().parents[1]


def _rotation(quaternion) -> np.ndarray:
    """Rotation matrix of a ROS quaternion [x, y, z, w] (pinocchio's, independent of the viewer's)."""
    import pinocchio as pin

    x, y, z, w = quaternion
    return pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()


@pytest.mark.parametrize(
    "quaternion",
    [
        [0, 0, 0, 1],
        [0, 0, math.sin(0.6), math.cos(0.6)],
        [math.sin(math.pi / 4), 0, 0, math.cos(math.pi / 4)],  # lying on its side
        [0.3, -0.5, 0.2, 0.78],
    ],
)
def test_an_object_label_sits_just_above_the_object_in_the_world(quaternion):
    size = np.array([0.06, 0.20, 0.10])
    R = _rotation(quaternion)
    world = R @ np.array(label_offset(quaternion, size))  # the label is a child: its offset turns with the box
    top = float(np.abs(R[2]) @ (size / 2))  # half the box's height in the world
    np.testing.assert_allclose(world, [0.0, 0.0, top + 0.08], atol=1e-9)


def test_scene_labels_are_placed_in_their_parent_nodes_frames(tmp_path):
    """Drawn into a real viser server: every object and place label is a child of its node, at the
    offset that puts it above that node (before, world coordinates added to the parent's: a cup at
    (4, 4.1, 0.8) got its label at (8, 8.2, ...))."""
    from placement.scene import load_scene
    from placement.viewer.scene_view import draw_scene
    from placement.viewer.server import start_server

    scene = load_scene(ROOT / "examples/kitchen.yaml")
    server = start_server(0)
    try:
        draw_scene(server, scene, 0.47)
        handles = dict(server.scene._handle_from_node_name)
    finally:
        server.stop()
    for o in scene.objects:
        label = handles[f"/scene/objects/{o.name}/label"]
        world = np.asarray(o.position) + _rotation(o.orientation) @ np.asarray(label.position)
        assert np.hypot(*(world[:2] - np.asarray(o.position[:2]))) < 1e-6, o.name
        assert 0.05 < world[2] - o.position[2] < max(o.size) + 0.1, o.name
    for p in scene.place_locations:
        np.testing.assert_allclose(handles[f"/scene/places/{p.name}/label"].position, [0, 0, 0.08])


def test_the_map_colour_scale_starts_at_the_planner_threshold_not_at_a_tiny_value():
    from placement.viewer.map_view import BELOW, value_scale

    rng = np.random.default_rng(0)
    values = np.concatenate([[1e-19, 1e-12], rng.uniform(0.0, 0.02, 300), rng.uniform(0.02, 0.2, 3000), [5.0]])
    scale = value_scale(values, "manipulability (best)")
    assert scale.lo == pytest.approx(placement.PlannerConfig().threshold)
    assert scale.hi == pytest.approx(np.percentile(values, 99))  # one outlier does not darken the rest
    # most reached cells are coloured, not at the dark end: the median lands mid-scale
    assert 0.25 < float(scale.normalise(np.median(values))) < 0.75
    assert BELOW[0] == BELOW[1] == BELOW[2] > 150  # cells below the scale: light grey, not dark
    # all values below the threshold: the scale spans them from their smallest
    low = value_scale(np.array([1e-5, 0.01, 0.02]), "x")
    assert (low.lo, low.hi) == (1e-5, pytest.approx(np.percentile([1e-5, 0.01, 0.02], 99)))


@pytest.mark.slow
def test_the_map_view_draws_weak_cells_small_and_cells_under_the_threshold_grey(maps_dir):
    from placement.viewer.api import view_map
    from placement.viewer.map_view import BELOW, BELOW_SIZE, SIZES

    v = view_map(maps_dir, arm="right", port=0)
    try:
        mv = v.content
        assert mv.scale.lo == pytest.approx(placement.PlannerConfig().threshold)
        below = mv.all_values < mv.scale.lo
        assert below.any() and mv.shown == mv.reached == len(mv.all_values)  # every cell is drawn at open
        grey = mv.clouds["/map/below"]
        assert len(grey.points) == below.sum() and (np.asarray(grey.colors) == BELOW).all()
        edge = mv.rmap.grid.resolution
        assert grey.point_size == pytest.approx(BELOW_SIZE * edge)
        drawn = [mv.clouds[f"/map/cells/{g}"] for g in range(len(SIZES))]
        assert sum(len(c.points) for c in drawn if c.visible) == (~below).sum()
        assert [c.point_size for c in drawn] == pytest.approx([s * edge for s in SIZES])
        assert SIZES == tuple(sorted(SIZES)) and BELOW_SIZE < SIZES[0]  # weaker cells smaller: the shell is open
        top = [c for c in drawn if c.visible][-1]
        assert not (np.asarray(top.colors) == BELOW).all(axis=1).any()
        assert "planner's threshold" in mv.scale_html.content
    finally:
        v.stop()


def test_the_legend_names_the_footprint_as_it_is_drawn(pr2):
    labels = {
        outline: [h.get_label() for h in legend_handles(_ok_step(), (0, 0, 0), True, outline)]
        for outline in (True, False)
    }
    assert any("footprint outline" in t for t in labels[True]) and not any("circle" in t for t in labels[True])
    assert any("footprint circle" in t for t in labels[False])
    assert pr2.footprint is not None  # the PR2's square: what query --plot draws, so the outline entry


def _ok_step(target="cup", step=0, action="pick"):
    return placed_step(step, action, target)


def test_figure_file_names_have_no_comma_and_a_bounded_length():
    assert file_name(_ok_step("drawer_left,drawer_right", 0, "reach")) == "step00_reach_drawer_left_or_drawer_right.png"
    assert file_name(_ok_step("cup 1/ü", 3)) == "step03_pick_cup-1.png"
    long = [file_name(_ok_step(",".join(f"trajectory_{k}" for k in range(n)), 1, "reach")) for n in (200, 201)]
    assert all(re.fullmatch(r"[A-Za-z0-9._-]+", n) and len(n) <= MAX_NAME + 20 for n in long)
    assert long[0] != long[1]  # cut names stay distinct


def _kitchen_reach(tmp_path, maps_dir) -> Path:
    doc = yaml.safe_load((ROOT / "examples/kitchen.yaml").read_text())
    doc["maps"] = str(maps_dir)
    doc["task"] = doc["task"][:1]  # the drawer pull: a reach step whose target is "drawer_left,drawer_right"
    path = tmp_path / "kitchen_reach.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


@pytest.mark.slow
def test_query_table_columns_fit_long_names_and_plot_says_where_it_wrote(tmp_path, maps_dir):
    from placement.cli.query import query

    plots = tmp_path / "plots"
    out = CliRunner().invoke(query, [str(_kitchen_reach(tmp_path, maps_dir)), "--plot", str(plots)])
    assert out.exit_code == 0, out.output + out.stderr
    files = sorted(p.name for p in plots.iterdir())
    assert files == ["step00_reach_drawer_left_or_drawer_right.png"]
    assert f"plots: 1 PNG file in {plots}" in out.stderr.splitlines()
    quiet = CliRunner().invoke(query, [str(_kitchen_reach(tmp_path, maps_dir)), "--plot", str(plots), "-q"])
    assert quiet.exit_code == 0 and "plots:" not in quiet.stderr
    header, row = out.stdout.splitlines()[1:3]
    assert "drawer_left,drawer_right" in row
    # every column ends where its header ends (right-aligned numbers) or starts where it starts
    for name in ("x [m]", "y [m]", "yaw [rad]", "manip", "cost", "travel [s]", "ms"):
        end = header.index(name) + len(name)
        assert row[end - 1] != " " and (end == len(row) or row[end] == " "), (name, header, row)
    for name in ("arm", "grasp"):
        assert row[header.index(name) - 1] == " " and row[header.index(name)] != " ", (name, header, row)
