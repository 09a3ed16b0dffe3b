"""Shared fixtures: the PR2 and an ARMAR-6 robot preset written on the fly.

The ARMAR-6 URDF is ``../shared/robots/armar6`` when that test data is there, else the ``armar``
package's (the ``test`` extra; see :func:`packaged_armar6_urdf`); the preset written into a temporary
directory references it by absolute path.
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".venv" / "numba-cache"))

import numpy as np
import pytest
import yaml
from skip_summary import pytest_terminal_summary  # noqa: F401  (the run's closing skip summary)

import placement

SHARED_ARMAR6_URDF = Path(__file__).resolve().parents[2] / "shared/robots/armar6/Armar6.urdf"

# The paper's hand frames on ARMAR-6's wrists (arm_t8_r0/r1), as in the pycram model in ../shared: the
# armar package's URDF has the same arms but names the hands hand_fixed_r0/r1 (another origin).
_PALMS = {"r0": ("Hand L Palm", "0 -1.57080 -1.57080"), "r1": ("Hand R Palm", "0 -1.57080 1.57080")}


def packaged_armar6_urdf(folder: Path) -> Path | None:
    """ARMAR-6 from the ``armar`` package (test extra), made loadable, written into ``folder``.

    The package's ``armar6.urdf`` has the same arms, torso and platform as ``../shared`` (joint names,
    types, limits and origins equal to the last digit); its meshes are real. Two edits make it the test
    robot: the one vector written with a comma (``rpy="1.5707963, 1.3089969 1.5707963"``, which urdfdom
    refuses) is read as meant, and the paper's palm frames are added. ``package://armar/...`` meshes
    resolve through a link to the installed package beside the file. None if ``armar`` is not installed.
    """
    try:
        import armar
    except ImportError:
        return None
    source = Path(armar.get_path_to_urdf_file("armar6"))
    text = source.read_text().replace('rpy="1.5707963, ', 'rpy="1.5707963 ')
    palms = "".join(
        f'  <joint name="palm_joint_{arm}" type="fixed">\n    <parent link="arm_t8_{arm}"/>\n'
        f'    <child link="{link}"/>\n    <origin rpy="{rpy}" xyz="0 0 0.14"/>\n  </joint>\n'
        f'  <link name="{link}"/>\n'
        for arm, (link, rpy) in _PALMS.items()
    )
    text = text.replace("</robot>", palms + "</robot>")
    folder.mkdir(parents=True, exist_ok=True)
    package = folder / "armar"
    if not os.path.lexists(package):
        try:
            package.symlink_to(source.parents[2], target_is_directory=True)
        except FileExistsError:  # another pytest worker made it
            pass
    path = folder / "armar6.urdf"
    if not path.is_file() or path.read_text() != text:
        part = folder / f"armar6.urdf.{os.getpid()}"
        part.write_text(text)
        os.replace(part, path)
    return path


def _armar6_urdf() -> tuple[Path, str]:
    """The ARMAR-6 URDF the tests use and where it comes from.

    ``../shared``'s pycram model when it is there (the fuller model the tests were written on: fingers,
    neck joints, mesh files absent), else the ``armar`` package's (a declared test dependency), so that
    a fresh clone runs the ARMAR-6 tests too. ``PLACEMENT_TEST_ARMAR6=package`` (or ``shared``) forces
    one.
    """
    import hashlib
    import tempfile

    choice = os.environ.get("PLACEMENT_TEST_ARMAR6", "auto")
    if choice == "shared" or (choice == "auto" and SHARED_ARMAR6_URDF.is_file()):
        return SHARED_ARMAR6_URDF, "shared"
    try:
        import armar
    except ImportError:
        return SHARED_ARMAR6_URDF, (
            "not found: neither ../shared/robots/armar6 nor the armar package (pip install -e '.[test]')"
        )
    key = hashlib.sha256(armar.__file__.encode()).hexdigest()[:10]  # one folder per installed package
    return packaged_armar6_urdf(Path(tempfile.gettempdir()) / f"placement-tests-armar6-{os.getuid()}-{key}"), "package"


ARMAR6_URDF, ARMAR6_SOURCE = _armar6_urdf()

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


def pytest_collection_modifyitems(config, items):
    if ARMAR6_SOURCE != "package":
        return
    for item in items:
        file, _, test = item.nodeid.partition("::")
        if f"{Path(file).name}::{test}" in NEEDS_PYCRAM_ARMAR6:
            item.add_marker(pytest.mark.skip(reason=PYCRAM_ONLY))


_ARMAR6_JOINTS = ("arm_t12", "arm_t23", "arm_t34", "arm_t45", "arm_t56", "arm_t67", "arm_t78", "arm_t8")

# Canonical TCP of the ARMAR-6 hand (test fixture choice): the fingers extend
# along the palm's x axis, so TCP z (approach) = palm x, a rotation of +90 deg
# about the palm's y axis, placed 10 cm out along the fingers and 4 cm off the palm.
ARMAR6_TCP_OFFSET = [0.10, 0.0, 0.04, 0.0, 0.7071067811865476, 0.0, 0.7071067811865476]


def armar6_spec(urdf: Path = ARMAR6_URDF) -> dict:
    """A robot preset (as a dict) for ARMAR-6 with both 8-DoF arms."""

    def arm(suffix: str, tip: str) -> dict:
        return {
            "joints": [f"{j}_joint_{suffix}" for j in _ARMAR6_JOINTS],
            "tip_frame": tip,
            "tcp_offset": list(ARMAR6_TCP_OFFSET),
        }

    return {
        "name": "armar6",
        "urdf": str(urdf),
        "base_frame": "platform",
        "fixed_joints": {"torso_joint": -0.2},
        "footprint_radius": 0.5,
        "v_max": 0.5,
        "omega_max": 1.0,
        "arms": {"left": arm("r0", "Hand L Palm"), "right": arm("r1", "Hand R Palm")},
    }


def write_armar6_preset(directory: Path) -> Path:
    """Write ``armar6.yaml`` into ``directory`` (pointing at the shared URDF) and return its path."""
    path = Path(directory) / "armar6.yaml"
    path.write_text(yaml.safe_dump(armar6_spec(), sort_keys=False))
    return path


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


def random_configs(arm, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, dof) configurations uniform within the arm's limits ([-pi, pi] for continuous joints)."""
    return arm.lower + (arm.upper - arm.lower) * rng.random((n, arm.dof))


@pytest.fixture(scope="session")
def maps_dir(pr2, tmp_path_factory):
    """Small PR2 maps (both arms) shared by the planning tests."""
    built = {
        arm: placement.build_map(pr2, arm, samples=700_000, seed=1, resolution=0.1, bins=(10, 5, 10), progress=False)
        for arm in ("right", "left")
    }
    return placement.save_maps(tmp_path_factory.mktemp("maps") / "pr2", pr2, built)
