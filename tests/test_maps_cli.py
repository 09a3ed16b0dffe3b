"""`placement maps build|info|check`: every bad option or spec is one `error:` line, exit 2, nothing written.

The options are refused before any sampling: the build below would take minutes
(``--samples`` 1e9 where it matters), so a test that passes quickly shows no work was done.
"""

from __future__ import annotations

import os
import stat

import pytest
from click.testing import CliRunner
from support.storage import SMALL, snapshot

import placement
from placement.cli.main import cli

BIG = "1000000000"  # a build this size would take many minutes: the errors must come first


def run(args, cwd):
    old = os.getcwd()
    os.chdir(cwd)
    try:
        return CliRunner().invoke(cli, args, catch_exceptions=False)
    finally:
        os.chdir(old)


def assert_one_line_error(result, *words):
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    for w in words:
        assert w in lines[0], lines[0]


@pytest.fixture
def work(tmp_path):
    """An empty working directory whose contents must not change."""
    d = tmp_path / "work"
    d.mkdir()
    return d


@pytest.mark.parametrize(
    "args,words",
    [
        (["--seed", "-1"], ["--seed", "from 0"]),
        (["--seed", "1.5"], ["--seed"]),
        (["--samples", "1e30"], ["--samples", "100,000,000,000"]),
        (["--samples", "1000000000000"], ["--samples", "100,000,000,000"]),
        (["--samples", "0"], ["--samples"]),
        (["--samples", "many"], ["--samples"]),
        (["--resolution", "-1"], ["--resolution"]),
        (["--resolution", "nan"], ["--resolution"]),
        (["--resolution", "x"], ["--resolution"]),
        (["--bins", "5"], ["--bins", "three"]),
        (["--bins", "a,b,c"], ["--bins"]),
        (["--bins", "20,0,20"], ["--bins"]),
        (["--bins", "20,8,20"], ["--bins", "odd"]),
        (["--index", "speed"], ["--index"]),
        (["--format", "csv"], ["--format"]),
        (["--arm", "middle"], ["middle", "right", "left"]),
        (["--robot", "pr3"], ["pr3"]),
    ],
)
def test_bad_build_options(work, args, words):
    assert_one_line_error(run(["maps", "build", "--samples", BIG, *args, "--out", "m"], work), *words)
    assert list(work.iterdir()) == []


def test_missing_out_is_one_line(work):
    assert_one_line_error(run(["maps", "build", "--samples", "10"], work), "--out")


@pytest.mark.parametrize(
    "text,words",
    [
        ("samples: many\n", ["samples", "'many'"]),
        ("seed: 1.5\n", ["seed", "1.5"]),
        ("bins: 5\n", ["bins"]),
        ("bins: [a, b, c]\n", ["bins"]),
        ("bins: [20, 9]\n", ["bins"]),
        ("bins: [20, -9, 20]\n", ["bins"]),
        ("resolution: -1\n", ["resolution"]),
        ("resolution: 0\n", ["resolution"]),
        ("resolution: fine\n", ["resolution"]),
        ("resolution: .nan\n", ["resolution"]),
        ("arms: [right, middle]\n", ["middle", "right, left"]),
        ("arms: 7\n", ["arms"]),
        ("index: speed\n", ["index"]),
        ("format: csv\n", ["format"]),
        ("self_collision: maybe\n", ["self_collision", "true or false"]),
        ("self_distance: 0\n", ["self_distance"]),
        ("wheels: 4\n", ["wheels"]),
        ("", ["non-empty mapping"]),
        ("[1, 2]\n", ["non-empty mapping"]),
        ("samples: [\n", ["not valid YAML"]),
    ],
)
def test_bad_spec(work, tmp_path, text, words):
    spec = tmp_path / "spec.yaml"
    spec.write_text(
        text + f"samples: {BIG}\n"
        if "samples" not in text and text.endswith("\n") and not text.startswith("[")
        else text
    )
    assert_one_line_error(run(["maps", "build", "--spec", str(spec), "--out", "m"], work), str(spec), *words)
    assert list(work.iterdir()) == []


def test_spec_is_a_directory_or_missing(work, tmp_path):
    assert_one_line_error(run(["maps", "build", "--spec", str(tmp_path), "--out", "m"], work), "directory")
    assert_one_line_error(run(["maps", "build", "--spec", "nope.yaml", "--out", "m"], work), "nope.yaml", "not found")
    assert list(work.iterdir()) == []


def test_arms_as_one_string_is_one_arm(work, tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text("arms: left\nsamples: 300\nresolution: 0.2\nbins: [4, 3, 4]\n")
    result = run(["maps", "build", "--spec", str(spec), "--out", "m", "-q"], work)
    assert result.exit_code == 0, result.output
    assert placement.open_map(work / "m", "left").store.root["arms"] == ["left"]


def test_out_below_a_file(work):
    (work / "file").write_text("x")
    before = snapshot(work)
    assert_one_line_error(run(["maps", "build", "--samples", BIG, "--out", "file/m"], work), "--out", "not a directory")
    assert_one_line_error(run(["maps", "build", "--samples", BIG, "--out", "file/deeper/m"], work), "not a directory")
    assert snapshot(work) == before


def test_out_is_an_existing_non_map(work):
    (work / "notes.txt").write_text("keep me")
    (work / "notes.h5").write_text("not hdf5")
    (work / "photos").mkdir()
    (work / "photos" / "a.jpg").write_bytes(b"\xff\xd8")
    before = snapshot(work)
    for out in ("notes.txt", "photos"):
        assert_one_line_error(run(["maps", "build", "--samples", BIG, "--out", out], work), "not a map")
    assert_one_line_error(
        run(["maps", "build", "--samples", BIG, "--format", "hdf5", "--out", "notes"], work), "notes.h5", "not a map"
    )
    assert snapshot(work) == before


@pytest.mark.slow
def test_out_is_a_map_of_another_robot_or_format(work, armar6, pr2):
    m = placement.build_map(armar6, "left", samples=300, seed=1, progress=False, **SMALL)
    placement.save_maps(work / "armar6", armar6, {"left": m})
    pm = placement.build_map(pr2, "right", samples=300, seed=1, progress=False, **SMALL)
    placement.save_maps(work / "pr2.h5", pr2, {"right": pm}, "zarr")  # a zarr directory with an HDF5 name
    before = snapshot(work)
    assert_one_line_error(run(["maps", "build", "--samples", BIG, "--out", "armar6"], work), "armar6", "pr2")
    assert_one_line_error(
        run(["maps", "build", "--samples", BIG, "--format", "hdf5", "--out", "pr2.h5"], work), "is a zarr map", "hdf5"
    )
    assert snapshot(work) == before


def test_out_in_a_read_only_directory(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(stat.S_IRUSR | stat.S_IXUSR)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as root: a read-only mode does not stop writes")
        assert_one_line_error(
            run(["maps", "build", "--samples", BIG, "--out", str(ro / "m")], tmp_path), "not writable"
        )
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(stat.S_IRWXU)


def test_out_where_nothing_can_be_created(tmp_path):
    """/proc refuses new directories even to root (access() alone would say yes to root)."""
    assert_one_line_error(
        run(["maps", "build", "--samples", BIG, "--out", "/proc/placement-map"], tmp_path), "--out", "not writable"
    )


@pytest.mark.parametrize(
    "args,words",
    [
        (["--samples", "0"], ["--samples"]),
        (["--samples", "1e9"], ["--samples", "5,000"]),
        (["--seed", "-1"], ["--seed"]),
        (["--seed", "x"], ["--seed"]),
    ],
)
def test_bad_check_options(work, args, words):
    assert_one_line_error(run(["maps", "check", "m", *args], work), *words)


@pytest.mark.slow
def test_info_and_check_on_a_sound_map(work, pr2):
    m = placement.build_map(pr2, "right", samples=2000, seed=1, progress=False, **SMALL)
    placement.save_maps(work / "m", pr2, {"right": m})
    result = run(["maps", "info", "m", "--json", "--full"], work)
    assert result.exit_code == 0, result.output
    import json

    doc = json.loads(result.output)
    arm = doc["arms"]["right"]
    assert arm["chunks_checked"] == 2 * m.grid.shape[2] * m.grid.shape[4] * m.grid.shape[5]  # values and witnesses
    assert "chunk_crc32" not in arm["meta"] and arm["filled_cells"] == m.meta["filled_cells"]
    result = run(["maps", "check", "m", "--samples", "3", "--json"], work)
    assert result.exit_code == 0, result.output
