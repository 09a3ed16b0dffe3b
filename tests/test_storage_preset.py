"""open_map compares the arm a map was built for (joints, tip frame, TCP offset) with the preset."""

from __future__ import annotations

import pytest
import yaml
from support.storage import SMALL, reseal_arm, set_root

import placement
from placement import MapError
from placement.robots.preset import PRESET_DIR


@pytest.fixture(scope="module")
def saved(pr2, tmp_path_factory):
    m = placement.build_map(pr2, "right", samples=2000, seed=2, progress=False, **SMALL)
    return placement.save_maps(tmp_path_factory.mktemp("maps") / "pr2", pr2, {"right": m})


def variant(tmp_path, edit) -> placement.Robot:
    """The PR2 preset with ``edit(right_arm_dict)`` applied, loaded from a copy in ``tmp_path``."""
    spec = yaml.safe_load((PRESET_DIR / "pr2.yaml").read_text())
    edit(spec["arms"]["right"])
    path = tmp_path / "pr2.yaml"
    path.write_text(yaml.safe_dump(spec))
    return placement.load_robot(path)


def shift_tcp(dx):
    def edit(arm):
        arm["tcp_offset"] = [dx, *arm["tcp_offset"][1:]]

    return edit


def test_same_preset_opens(saved, tmp_path):
    robot = variant(tmp_path, lambda arm: None)
    assert placement.open_map(saved, "right", robot=robot).arm == "right"
    # below the 1e-9 tolerance: the same TCP
    assert placement.open_map(saved, "right", robot=variant(tmp_path, shift_tcp(1e-12))).arm == "right"


@pytest.mark.parametrize("dx", [1e-6, 0.01])
def test_tcp_offset_differs(saved, tmp_path, dx):
    with pytest.raises(MapError, match="arm 'right' was built for TCP offset .*the preset has .*rebuild the map"):
        placement.open_map(saved, "right", robot=variant(tmp_path, shift_tcp(dx)))


def test_tcp_rotation_differs(saved, tmp_path):
    def edit(arm):
        arm["tcp_offset"] = [0, 0, 0, 0, 0, 0, 1]

    with pytest.raises(MapError, match="TCP offset"):
        placement.open_map(saved, "right", robot=variant(tmp_path, edit))


def test_tip_frame_differs(saved, tmp_path):
    def edit(arm):
        arm["tip_frame"] = "r_gripper_palm_link"

    with pytest.raises(MapError, match="tip frame r_gripper_tool_frame, the preset has r_gripper_palm_link"):
        placement.open_map(saved, "right", robot=variant(tmp_path, edit))


def test_six_joint_arm_against_a_seven_joint_map(saved, tmp_path):
    """A 6-joint preset arm against the 7-joint map of that arm."""

    def edit(arm):
        arm["joints"] = arm["joints"][:6]
        arm["home"] = arm["home"][:6]
        arm.pop("idle", None)

    with pytest.raises(MapError, match="joints .*r_wrist_roll_joint.*the preset has"):
        placement.open_map(saved, "right", robot=variant(tmp_path, edit))


def test_joint_order_differs(saved, tmp_path, pr2):
    """A preset cannot list joints out of chain order, so the map's stored order is edited instead."""
    import shutil

    import zarr

    other = tmp_path / "other"
    shutil.copytree(saved, other)
    arr = zarr.open_group(str(other), mode="r+")["right"]
    joints = list(arr.attrs["joints"])
    arr.attrs["joints"] = joints[:5] + joints[5:][::-1]
    reseal_arm(other, "right")
    with pytest.raises(MapError, match="joints .*r_wrist_roll_joint', 'r_wrist_flex_joint'.*the preset has"):
        placement.open_map(other, "right", robot=pr2)


@pytest.mark.slow
def test_stored_arm_metadata_damaged(tmp_path, pr2):
    """Missing or malformed arm fields and chunk checksums in the file: a MapError, not a traceback."""
    m = placement.build_map(pr2, "right", samples=500, seed=2, progress=False, **SMALL)
    for field, value, words in [
        ("tcp_offset", "x", "TCP offset"),
        ("tcp_offset", [[1, 2]], "TCP offset"),
        ("joints", None, "joints"),
        ("tip_frame", 3, "tip.frame"),
        ("chunk_crc32", [1, 2], "checksums"),
        ("chunk_crc32", None, "checksums"),
    ]:
        path = placement.save_maps(tmp_path / f"m-{field}-{type(value).__name__}", pr2, {"right": m})
        import zarr

        arr = zarr.open_group(str(path), mode="r+")["right"]
        arr.attrs[field] = value
        with pytest.raises(MapError, match=f"key '{field}' changed"):
            placement.open_map(path, "right")
        reseal_arm(path, "right")  # as if written so (or a map without digests): the field checks still hold
        with pytest.raises(MapError, match=words):
            placement.open_map(path, "right")


def test_old_format_version_says_rebuild(saved, tmp_path):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(saved, old)
    set_root(old, "zarr", lambda root: root.update(format_version=1))
    with pytest.raises(MapError, match="format version 1 is not supported.*rebuild it"):
        placement.open_map(old, "right")
