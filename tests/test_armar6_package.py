"""ARMAR-6 from the armar package (a test dependency): the robot the ARMAR-6 tests use where
../shared is missing. Checked against ../shared's model whenever both are there, so the fallback
stays the same robot."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
import yaml
from support.robots import SHARED_ARMAR6_URDF, armar6_spec, packaged_armar6_urdf

import placement


@pytest.fixture(scope="module")
def packaged(tmp_path_factory):
    path = packaged_armar6_urdf(tmp_path_factory.mktemp("armar6-package"))
    if path is None:
        pytest.skip("the armar package is not installed (pip install -e '.[test]')")
    return path


def _shared():
    if not SHARED_ARMAR6_URDF.is_file():
        pytest.skip(f"{SHARED_ARMAR6_URDF} is not there to compare with")
    return SHARED_ARMAR6_URDF


def _robot(urdf, folder):
    spec = armar6_spec(urdf)
    spec["name"] = f"armar6_{folder.name}"
    path = folder / "armar6.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return placement.load_robot(path)


def test_the_package_urdf_as_shipped_does_not_load_and_the_fixture_repairs_it(packaged):
    import armar

    shipped = armar.get_path_to_urdf_file("armar6")
    with pytest.raises(ValueError):  # urdfdom: 'Unable to parse component [1.5707963,] to a double'
        pin.buildModelFromUrdf(shipped)
    model = pin.buildModelFromUrdf(str(packaged))
    assert model.existFrame("Hand L Palm") and model.existFrame("Hand R Palm")
    # the package's meshes, found through the link beside the file (the collision check searches the
    # URDF's folders)
    geometry = pin.buildGeomFromUrdf(
        model, str(packaged), pin.GeometryType.COLLISION, package_dirs=[str(packaged.parent)]
    )
    assert geometry.ngeoms == 25


def test_the_package_arms_are_the_shared_arms(packaged):
    a = pin.buildModelFromUrdf(str(_shared()))
    b = pin.buildModelFromUrdf(str(packaged))
    movable = [n for n in b.names[1:]]
    assert len(movable) == 17 and all(a.existJointName(n) for n in movable)  # torso + 2 x 8 arm joints
    for name in movable:
        ja, jb = a.joints[a.getJointId(name)], b.joints[b.getJointId(name)]
        assert ja.shortname() == jb.shortname(), name
        sa, sb = slice(ja.idx_q, ja.idx_q + ja.nq), slice(jb.idx_q, jb.idx_q + jb.nq)
        np.testing.assert_array_equal(a.lowerPositionLimit[sa], b.lowerPositionLimit[sb], err_msg=name)
        np.testing.assert_array_equal(a.upperPositionLimit[sa], b.upperPositionLimit[sb], err_msg=name)
        assert a.velocityLimit[ja.idx_v] == b.velocityLimit[jb.idx_v], name
        np.testing.assert_allclose(
            a.jointPlacements[a.getJointId(name)].homogeneous,
            b.jointPlacements[b.getJointId(name)].homogeneous,
            atol=1e-12,
            err_msg=name,
        )
        assert a.names[a.parents[a.getJointId(name)]] == b.names[b.parents[b.getJointId(name)]]


def test_the_package_robot_puts_the_tcp_where_the_shared_robot_does(packaged, tmp_path):
    shared = _shared()
    (tmp_path / "p").mkdir()
    (tmp_path / "s").mkdir()
    ours, theirs = _robot(packaged, tmp_path / "p"), _robot(shared, tmp_path / "s")
    rng = np.random.default_rng(19)
    for arm in ("left", "right"):
        a = ours.arm(arm)
        assert a.joints == theirs.arm(arm).joints
        np.testing.assert_array_equal(a.lower, theirs.arm(arm).lower)
        np.testing.assert_array_equal(a.upper, theirs.arm(arm).upper)
        for q in a.lower + (a.upper - a.lower) * rng.random((20, a.dof)):
            np.testing.assert_allclose(ours.tcp_pose(arm, q), theirs.tcp_pose(arm, q), atol=1e-12)
