"""Shared fixtures: the PR2 and an ARMAR-6 robot preset written on the fly.

The ARMAR-6 URDF is test data outside the project (``../shared/robots/armar6``);
it is referenced by absolute path from a preset written into a temporary
directory and never copied.
"""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".venv" / "numba-cache"))

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import yaml  # noqa: E402

import placement  # noqa: E402
from skip_summary import pytest_terminal_summary  # noqa: E402,F401  (the run's closing skip summary)

ARMAR6_URDF = Path(__file__).resolve().parents[2] / "shared/robots/armar6/Armar6.urdf"

_ARMAR6_JOINTS = ("arm_t12", "arm_t23", "arm_t34", "arm_t45", "arm_t56", "arm_t67", "arm_t78", "arm_t8")

# Canonical TCP of the ARMAR-6 hand (test fixture choice): the fingers extend
# along the palm's x axis, so TCP z (approach) = palm x, a rotation of +90 deg
# about the palm's y axis, placed 10 cm out along the fingers and 4 cm off the palm.
ARMAR6_TCP_OFFSET = [0.10, 0.0, 0.04, 0.0, 0.7071067811865476, 0.0, 0.7071067811865476]


def armar6_spec(urdf: Path = ARMAR6_URDF) -> dict:
    """A robot preset (as a dict) for ARMAR-6 with both 8-DoF arms."""
    def arm(suffix: str, tip: str) -> dict:
        return {"joints": [f"{j}_joint_{suffix}" for j in _ARMAR6_JOINTS], "tip_frame": tip,
                "tcp_offset": list(ARMAR6_TCP_OFFSET)}

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
        pytest.skip(f"ARMAR-6 test URDF not found at {ARMAR6_URDF} (shared test data is not available)")
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
    built = {arm: placement.build_map(pr2, arm, samples=700_000, seed=1, resolution=0.1, bins=(10, 5, 10),
                                      progress=False) for arm in ("right", "left")}
    return placement.save_maps(tmp_path_factory.mktemp("maps") / "pr2", pr2, built)
