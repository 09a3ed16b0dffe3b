"""Robots the tests share: the ARMAR-6 preset written on the fly and random configurations.

The ARMAR-6 URDF is ``../shared/robots/armar6`` when that test data is there, else the ``armar``
package's (the ``test`` extra; see :func:`packaged_armar6_urdf`); the preset written into a temporary
directory references it by absolute path.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import yaml

SHARED_ARMAR6_URDF = Path(__file__).resolve().parents[3] / "shared/robots/armar6/Armar6.urdf"

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


def armar6_urdf() -> tuple[Path, str]:
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


ARMAR6_URDF, ARMAR6_SOURCE = armar6_urdf()

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


def random_configs(arm, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, dof) configurations uniform within the arm's limits ([-pi, pi] for continuous joints)."""
    return arm.lower + (arm.upper - arm.lower) * rng.random((n, arm.dof))
