"""A map is one checked document: changed metadata, damaged bytes and hostile files are one clean error.

Every case is made to a real, freshly saved map (Zarr and HDF5) and then opened through the API and
through `placement maps info` / `maps verify` (exit 2, exactly one `error:` line), or it gives the
same result as the undamaged map. Files that would block or never end (a FIFO, /dev/zero) are read
in a fresh process under a timeout, so a regression fails instead of hanging the suite.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import warnings
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from support.storage import set_root, zarr_chunk_files

import placement
from placement import MapError
from placement.cli.main import cli
from placement.storage.digest import DIGEST_KEY
from placement.storage.format import ROOT_KEY

ROOT = Path(__file__).resolve().parents[1]
FORMATS = ["zarr", "hdf5"]


@pytest.fixture(scope="module")
def sources(pr2, right_map, left_map, tmp_path_factory):
    """One sound two-arm map per format, copied by each test that damages it."""
    d = tmp_path_factory.mktemp("trust")
    return {
        fmt: placement.save_maps(
            d / ("pr2" + placement.storage.backend(fmt).suffix), pr2, {"right": right_map, "left": left_map}, fmt
        )
        for fmt in FORMATS
    }


def copy_map(src: Path, dst_dir: Path) -> Path:
    dst = dst_dir / src.name
    if src.is_dir():
        import shutil

        shutil.copytree(src, dst)
    else:
        dst.write_bytes(src.read_bytes())
    return dst


def info(path, *extra):
    return CliRunner().invoke(cli, ["maps", "info", str(path), "--json", *extra], catch_exceptions=False)


def one_line_error(result, *words) -> str:
    assert result.exit_code == 2, result.output[-2000:]
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output[-2000:]
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def edit_arm_meta(path: Path, fmt: str, arm: str, edit) -> None:
    """Apply ``edit(meta)`` to an arm's stored metadata, data untouched (the root's digest is not updated)."""
    if fmt == "zarr":
        f = path / arm / "zarr.json"
        doc = json.loads(f.read_text())
        edit(doc["attributes"])
        f.write_text(json.dumps(doc))
    else:
        with h5py.File(path, "r+") as fh:
            meta = json.loads(fh[arm].attrs["meta"])
            edit(meta)
            fh[arm].attrs["meta"] = json.dumps(meta)


def shift_origin(m):
    m["grid"]["origin"][0] += 0.5


def double_resolution(m):
    m["grid"]["resolution"] *= 2


def other_seed(m):
    m["seed"] += 1


def other_samples(m):
    m["samples"] += 1


def other_crc(m):
    m["chunk_crc32"][0][0][0] ^= 1


def other_witness_crc(m):
    m["witness_crc32"][1][1][1] ^= 1


def other_index(m):
    m["measure"]["index"] = "volume"


def other_tcp(m):
    m["tcp_offset"][2][3] += 0.01


def other_witness_numbering(m):
    m["witness"]["plain_samples"] += 1


ARM_EDITS = {
    shift_origin: "grid.origin",
    double_resolution: "grid.resolution",
    other_seed: "seed",
    other_samples: "samples",
    other_crc: "chunk_crc32",
    other_witness_crc: "witness_crc32",
    other_index: "measure.index",
    other_tcp: "tcp_offset",
    other_witness_numbering: "witness.plain_samples",
}


@pytest.mark.slow
@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("edit", list(ARM_EDITS), ids=lambda e: e.__name__)
def test_changed_arm_metadata_is_named(sources, tmp_path, fmt, edit):
    path = copy_map(sources[fmt], tmp_path)
    edit_arm_meta(path, fmt, "right", edit)
    key = ARM_EDITS[edit]
    with pytest.raises(MapError, match=f"metadata of arm 'right' does not match its digest \\(key '{key}' changed"):
        placement.open_map(path, "right")
    placement.open_map(path, "left").verify()  # the other arm is sound and still opens
    one_line_error(info(path), f"key '{key}' changed")


ROOT_EDITS = {
    "fixed_joints.torso_lift_joint": lambda r: r["fixed_joints"].update(torso_lift_joint=0.2),
    "arms": lambda r: r.update(arms=["right"]),
    "format_version": lambda r: r.update(format_version=3),
    "preset": lambda r: r.update(preset="pr2-other"),
    "digests": lambda r: r[DIGEST_KEY]["arms"]["right"].update(document="0" * 64),
}


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("key", list(ROOT_EDITS))
def test_changed_root_metadata_is_named(sources, tmp_path, fmt, key):
    path = copy_map(sources[fmt], tmp_path)
    set_root(path, fmt, ROOT_EDITS[key], reseal=False)
    want = "metadata of arm 'right'" if key == "digests" else f"root metadata does not match its digest (key '{key}'"
    with pytest.raises(MapError, match="digest"):
        placement.open_map(path, "right")
    one_line_error(info(path), want)


WRONG_TYPES = {
    "fixed joint value a string": (lambda r: r["fixed_joints"].update(torso_lift_joint="high"), "fixed_joints."),
    "fixed joint value a list": (lambda r: r["fixed_joints"].update(torso_lift_joint=[1, 2]), "fixed_joints."),
    "fixed joints a number": (lambda r: r.update(fixed_joints=3), "fixed_joints"),
    "arms a number": (lambda r: r.update(arms=5), "arms"),
    "arms a string": (lambda r: r.update(arms="right"), "arms"),
    "empty arm list": (lambda r: r.update(arms=[]), "arms"),
    "robot a list": (lambda r: r.update(robot=["pr2"]), "robot"),
    "root a list": (None, "not a mapping"),
}


@pytest.mark.parametrize("reseal", [False, True], ids=["changed", "resealed"])
@pytest.mark.parametrize("case", list(WRONG_TYPES))
def test_root_metadata_is_validated_like_a_preset(sources, tmp_path, case, reseal):
    """Wrong types in the root are one line naming the key, also when the digest was made to match;
    an empty arm list fails info and verify."""
    path = copy_map(sources["zarr"], tmp_path)
    edit, key = WRONG_TYPES[case]
    if edit is None:
        doc = json.loads((path / "zarr.json").read_text())
        doc["attributes"][ROOT_KEY] = [doc["attributes"][ROOT_KEY]]
        (path / "zarr.json").write_text(json.dumps(doc))
    else:
        set_root(path, "zarr", edit, reseal=reseal)
    with pytest.raises(MapError, match=key):
        placement.open_map(path, "right")
    one_line_error(info(path), key)
    verify = CliRunner().invoke(cli, ["maps", "verify", str(path)], catch_exceptions=False)
    one_line_error(verify, key)


@pytest.mark.parametrize("fmt", FORMATS)
def test_a_map_without_digests(sources, tmp_path, fmt):
    """Format 3 (before the digests): read with one warning; format 4 without its digests: an error."""
    path = copy_map(sources[fmt], tmp_path)
    set_root(path, fmt, lambda r: r.pop(DIGEST_KEY), reseal=False)
    with pytest.raises(MapError, match="no metadata digests"):
        placement.open_map(path, "right")
    set_root(path, fmt, lambda r: r.update(format_version=3), reseal=False)
    with pytest.warns(UserWarning, match="format version 3 has no metadata digests"):
        placement.open_map(path, "right").verify()
    with warnings.catch_warnings():
        warnings.simplefilter("default")
        result = CliRunner().invoke(cli, ["maps", "info", str(path)], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert [ln for ln in result.output.splitlines() if ln.startswith("warning:")] == [
        f"warning: {path}: map of format version 3 has no metadata digests, so changed metadata goes unnoticed; "
        f"rebuild it to have it checked"
    ]


def test_info_full_reads_every_witness_chunk(sources, tmp_path, right_map):
    """A witness chunk rewritten with valid bytes (other data) fails info --full, naming the witness chunk."""
    import zarr

    path = copy_map(sources["zarr"], tmp_path)
    iz, _, _, _, ip, ir = np.unravel_index(np.flatnonzero(right_map.values)[0], right_map.values.shape)
    arr = zarr.open_group(str(path), mode="r+")["right.witness"]
    block = arr[:, :, iz, :, ip, ir]
    arr[:, :, iz, :, ip, ir] = np.where(block == block.max(), block, block + 1)
    one_line_error(info(path, "--full"), f"witness chunk (z, pitch, roll) = ({iz}, {ip}, {ir})", "checksum")


# --------------------------------------------------------------------------------------------
# Bytes flipped anywhere in an HDF5 file: a clean error, or exactly the sound map's result
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def hdf5_truth(sources):
    src = sources["hdf5"]
    result = info(src, "--full")
    assert result.exit_code == 0
    doc = json.loads(result.output)
    rmaps = {a: placement.open_map(src, a) for a in ("right", "left")}
    return src.read_bytes(), doc, {a: (m.values, m.witness) for a, m in rmaps.items()}


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.0, 0.9999), flip=st.integers(1, 255))
@example(where=0.3, flip=0x10).via("30-40 %")
@example(where=0.37, flip=0x01).via("30-40 %")
@example(where=0.8, flip=0x80).via("80-99 %")
@example(where=0.9, flip=0x04).via("80-99 %")
@example(where=0.99, flip=0xFF).via("80-99 %")
def test_hdf5_bytes_flipped_anywhere(hdf5_truth, tmp_path_factory, where, flip):
    data, doc, arrays = hdf5_truth
    damaged = bytearray(data)
    offset = int(where * len(data))
    damaged[offset] ^= flip
    path = tmp_path_factory.mktemp("flip") / "pr2.h5"
    path.write_bytes(bytes(damaged))
    result = info(path, "--full")
    if result.exit_code == 2:
        one_line_error(result)
        return
    assert result.exit_code == 0, result.output[-2000:]
    got = json.loads(result.output)
    assert {**got, "path": None} == {**doc, "path": None}, f"byte {offset} changed the result without an error"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for arm, (values, witness) in arrays.items():
            m = placement.open_map(path, arm)
            np.testing.assert_array_equal(m.values, values)
            np.testing.assert_array_equal(m.witness, witness)


# --------------------------------------------------------------------------------------------
# Files that are not regular files of a sane size: never read
# --------------------------------------------------------------------------------------------


def run_cli(*args, timeout=60):
    """A command in a fresh process under a timeout (a blocking read would fail the test, not hang it)."""
    return subprocess.run(
        [sys.executable, "-m", "placement.cli.main", *args], capture_output=True, text=True, cwd=ROOT, timeout=timeout
    )


def assert_refused(p, *words):
    assert p.returncode == 2, p.stderr[-2000:]
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), p.stderr[-2000:]
    for w in words:
        assert w in lines[0], lines[0]


def largest_chunk(path: Path, name: str = "right") -> Path:
    return max(zarr_chunk_files(path, name), key=lambda f: f.stat().st_size)


def replace_with_fifo(f: Path) -> None:
    f.unlink()
    os.mkfifo(f)


def replace_with_dev_zero(f: Path) -> None:
    f.unlink()
    f.symlink_to("/dev/zero")


def replace_with_loop(f: Path) -> None:
    f.unlink()
    f.symlink_to(f.name)


def guarded(fn, timeout: float = 30.0):
    """``fn()`` in a daemon thread: a read that blocks fails the test after ``timeout`` instead of hanging it."""
    out: list = []
    thread = threading.Thread(target=lambda: out.append(fn()), daemon=True)
    thread.start()
    thread.join(timeout)
    assert not thread.is_alive(), f"still running after {timeout} s (a blocking or endless read)"
    return out[0] if out else None


HOSTILE = [
    (replace_with_fifo, "is a FIFO"),
    (replace_with_dev_zero, "is a character device"),
    (replace_with_loop, "symbolic links"),
]


@pytest.mark.parametrize("replace, words", HOSTILE, ids=["fifo", "dev-zero", "link-loop"])
@pytest.mark.parametrize("name", ["right", "right.witness"])
def test_hostile_chunk_files(sources, tmp_path, replace, words, name):
    path = copy_map(sources["zarr"], tmp_path)
    replace(largest_chunk(path, name))

    def read():
        with pytest.raises(MapError, match=words) as exc:
            placement.open_map(path, "right").store.read_all("right", witness=name.endswith("witness"))
        return exc

    guarded(read)
    one_line_error(guarded(lambda: info(path, "--full")), "rebuild the map", words)
    verify = guarded(lambda: CliRunner().invoke(cli, ["maps", "verify", str(path), "-q"], catch_exceptions=False))
    one_line_error(verify, "rebuild the map", words)


@pytest.mark.slow
def test_fifo_chunk_from_the_command_line(sources, tmp_path):
    """The same in a fresh process, as a user runs it: exit 2 and one line within the timeout."""
    path = copy_map(sources["zarr"], tmp_path)
    replace_with_fifo(largest_chunk(path, "right.witness"))
    assert_refused(run_cli("maps", "info", str(path), "--full"), "is a FIFO")
    assert_refused(run_cli("maps", "verify", str(path), "-q"), "is a FIFO")


@pytest.mark.parametrize("meta", ["zarr.json", "right/zarr.json", "right.witness/zarr.json"])
@pytest.mark.parametrize("replace, words", HOSTILE[:2], ids=["fifo", "dev-zero"])
def test_hostile_metadata_files(sources, tmp_path, meta, replace, words):
    path = copy_map(sources["zarr"], tmp_path)
    replace(path / meta)
    one_line_error(guarded(lambda: info(path)), words)


def test_a_metadata_file_too_large_is_not_read(sources, tmp_path):
    from placement.storage.files import META_LIMIT

    path = copy_map(sources["zarr"], tmp_path)
    with open(path / "right" / "zarr.json", "r+b") as fh:
        fh.truncate(META_LIMIT + 1)  # sparse: costs no disk
    one_line_error(guarded(lambda: info(path)), "more than")


@pytest.mark.parametrize("replace", [replace_with_fifo, replace_with_dev_zero], ids=["fifo", "dev-zero"])
def test_hostile_hdf5_file(sources, tmp_path, replace):
    path = copy_map(sources["hdf5"], tmp_path)
    replace(path)
    one_line_error(guarded(lambda: info(path)), "not a reachability map")


def test_hdf5_dataset_linked_to_another_file(sources, tmp_path):
    """An external link (or external storage) could point anywhere: only datasets of the file are read."""
    path = copy_map(sources["hdf5"], tmp_path)
    (tmp_path / "elsewhere").mkdir()
    other = copy_map(sources["hdf5"], tmp_path / "elsewhere")
    with h5py.File(path, "r+") as fh:
        meta = fh["right.witness"].attrs.get("meta")
        del fh["right.witness"]
        fh["right.witness"] = h5py.ExternalLink(str(other), "right.witness")
        assert meta is None
    one_line_error(info(path), "not a dataset of this file")
