"""Shared fixtures: the robots (PR2, ARMAR-6 written on the fly), small maps, the closing skip summary.

Plain helpers live in ``tests/support`` (the ARMAR-6 URDF and preset in :mod:`support.robots`).
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".venv" / "numba-cache"))
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as placement.process_env sets it for every entry point
# The command-line tests start ~200 Python processes that import placement; with PYTHONDONTWRITEBYTECODE
# (set in some containers) each compiled the package's sources again (0.2 s a process). Their bytecode
# goes to a cache outside the working tree instead.
if os.environ.pop("PYTHONDONTWRITEBYTECODE", None):
    os.environ.setdefault("PYTHONPYCACHEPREFIX", str(Path(tempfile.gettempdir()) / "placement-test-pycache"))

import pytest
from hypothesis import settings
from skip_summary import pytest_terminal_summary  # noqa: F401  (the run's closing skip summary)
from support.robots import ARMAR6_SOURCE, ARMAR6_URDF, write_armar6_preset
from support.storage import SMALL
from support.workers import built_once, run_dir

import placement

# Property tests: "ci" (the default) tries a moderate number of examples per property, enough to catch a
# broken invariant on the shapes the strategies favour while the suite stays within CI's time; "deep"
# (HYPOTHESIS_PROFILE=deep) tries 2000, the counts these tests were written with, for a thorough run.
# Each test's @example corner cases run under both. Loaded here, before any test module is imported, so
# that every @settings without max_examples inherits the profile's.
settings.register_profile("ci", max_examples=50, deadline=None)
settings.register_profile("deep", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

# Tests of structure only the pycram model in ../shared has; skipped with the armar package's model.
NEEDS_PYCRAM_ARMAR6 = {
    "test_collision.py::test_armar6_decisions_and_clearances_equal_plain_coal",  # > 40 collision meshes (25)
    "test_collision.py::test_armar6_missing_meshes_warn_and_the_rest_is_checked",  # a mesh on 'Hand R Palm'
    "test_robots_init.py::test_init_finds_the_urdf_arm_chains[armar6]",  # the neck joint neck_2_pitch
    "test_robots_init.py::test_tcp_z_points_from_the_wrist_to_the_fingers[armar6]",  # finger frames
    "test_collision_cases.py::test_robot_without_collision_geometry_warns_and_is_never_blocked",  # no meshes
    "test_selfcollision.py::test_missing_collision_geometry_is_one_clear_error",  # no mesh files
}
PYCRAM_ONLY = (
    "needs ../shared's ARMAR-6 model (fingers, neck joints, no mesh files); the armar package's "
    "has the same arms and torso, no fingers or neck joints, and its meshes"
)


# The slowest test files (worker-seconds of `pytest -n 2`: 190, 108, 83, ... 24), collected first: with
# --dist loadfile (pyproject.toml) a file is one unit of work, handed out in collection order, so the long
# ones start early and the two workers end together. Speed only: a file not listed runs after these.
FIRST = (
    "test_plans_on_tiny_maps.py",
    "test_search.py",
    "test_cli.py",
    "test_regression.py",
    "test_footprints.py",
    "test_robots_init.py",
    "test_witness.py",
    "test_storage_damage.py",
    "test_query_cli.py",
    "test_warmup.py",
    "test_manipulability.py",
    "test_transfers.py",
    "test_planner.py",
    "test_torso_builds.py",
    "test_build.py",
    "test_torso_planning.py",
    "test_torso_maps.py",
    "test_viewer_cli.py",
    "test_selfcollision.py",
    "test_certificate.py",
)


#: collected last: headless Chromium renders WebGL in software and timed out (3 x 45 s) when it ran first,
#: beside the session's map build on the other worker
LAST = ("test_viewer_browser.py",)


#: fixtures that build maps, a docs site or whole plans: a test that uses one is in the integration tier
#: (``slow``; `make test` leaves it out, `make test-all` runs it)
SLOW_FIXTURES = frozenset(
    {
        "maps_dir",  # the planning maps (700 k samples per arm)
        "proposed",  # robots init of every example-robot-data robot
        "torso_maps",
        "stored",
        "built",
        "built_small",
        "knee",
        "pitch",
        "figures",
        "planned",
        "site",  # the docs site
        "saved",
        "completed",
        "small_map",
        "coarse_map",
    }
)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    for item in items:
        if SLOW_FIXTURES.intersection(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
    rank = {name: k for k, name in enumerate(FIRST)} | {name: len(FIRST) + 1 + k for k, name in enumerate(LAST)}
    items.sort(key=lambda item: rank.get(Path(item.nodeid.partition("::")[0]).name, len(FIRST)))  # stable
    if ARMAR6_SOURCE != "package":
        return
    for item in items:
        file, _, test = item.nodeid.partition("::")
        if f"{Path(file).name}::{test}" in NEEDS_PYCRAM_ARMAR6:
            item.add_marker(pytest.mark.skip(reason=PYCRAM_ONLY))


@pytest.fixture(scope="session")
def armar6_preset(tmp_path_factory) -> Path:
    """Path of an ARMAR-6 preset YAML in a temporary directory (skips if the URDF is missing)."""
    if not ARMAR6_URDF.is_file():
        pytest.skip(f"ARMAR-6 URDF {ARMAR6_SOURCE}")
    return write_armar6_preset(tmp_path_factory.mktemp("armar6"))


@pytest.fixture(scope="session")
def armar6(armar6_preset):
    """The ARMAR-6 :class:`placement.Robot` (session-scoped)."""
    import placement

    return placement.load_robot(armar6_preset)


@pytest.fixture(scope="session")
def pr2():
    """The built-in PR2 :class:`placement.Robot` (session-scoped)."""
    import placement

    return placement.load_robot("pr2")


@pytest.fixture(scope="session")
def maps_dir(pr2, tmp_path_factory, worker_id):
    """Small PR2 maps (both arms) shared by the planning tests: built once per run, by the first
    pytest-xdist worker that needs them (read-only for every test)."""

    # not ".../maps/pr2": scenes without a 'maps' key look for maps/pr2 in every parent of their folder
    return _shared_pr2_maps(pr2, tmp_path_factory, worker_id, "planning-maps", 700_000, 0.1)


@pytest.fixture(scope="session")
def tiny_maps(pr2, tmp_path_factory, worker_id):
    """Tiny PR2 maps (both arms; 150 k samples, 0.15 m cells, 10 x 5 x 10 bins: 4-9 s) for the fast
    tier's whole plans: coarse, but every example scene plans on them. Built once per run, by the
    first pytest-xdist worker that needs them (read-only for every test)."""

    return _shared_pr2_maps(pr2, tmp_path_factory, worker_id, "tiny-maps", 150_000, 0.15)


def _shared_pr2_maps(pr2, tmp_path_factory, worker_id, name: str, samples: int, resolution: float) -> Path:
    """PR2 maps of both arms (``samples``, ``resolution`` [m] cells, 10 x 5 x 10 bins, seed 1) in
    ``<run>/<name>/pr2``, built by the first pytest-xdist worker that asks and read by the others."""

    def build(folder: Path) -> None:
        built = {
            arm: placement.build_map(
                pr2, arm, samples=samples, seed=1, resolution=resolution, bins=(10, 5, 10), progress=False
            )
            for arm in ("right", "left")
        }
        placement.save_maps(folder / "pr2", pr2, built)

    return built_once(run_dir(tmp_path_factory, worker_id), name, build) / "pr2"


@pytest.fixture(scope="module")
def right_map(pr2):
    """A small PR2 right-arm map (0.2 m cells, 4000 samples), built once per test module."""
    return placement.build_map(pr2, "right", samples=4000, seed=2, progress=False, **SMALL)


@pytest.fixture(scope="module")
def left_map(pr2):
    """A small PR2 left-arm map (0.2 m cells, 1000 samples), built once per test module."""
    return placement.build_map(pr2, "left", samples=1000, seed=3, progress=False, **SMALL)


@pytest.fixture
def robot(request):
    """The robot fixture named by an indirect parameter (``"pr2"`` or ``"armar6"``)."""
    return request.getfixturevalue(request.param)
