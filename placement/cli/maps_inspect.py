"""`placement maps info | check | verify`: what a built map holds, how accurate it is against IK, and
whether its stored values follow from their witnesses."""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import click
from tqdm import tqdm

from placement.cli.maps_build import SEED, count_type
from placement.cli.options import (
    arm_option,
    emit,
    map_argument,
    robot_option,
    samples_option,
    setup_logging,
    standard_options,
)
from placement.cli.params import OneLineCommand
from placement.errors import MapError
from placement.maps.accuracy import MAX_CHECK_SAMPLES, check_map, pose_metrics
from placement.maps.opening import open_map
from placement.maps.rmap import ReachabilityMap, check_root
from placement.maps.torso import TorsoSettings
from placement.maps.witness import verify_witnesses
from placement.progress import EtaBar
from placement.robots import Robot, load_robot
from placement.storage import open_store
from placement.storage.digest import DIGEST_KEY
from placement.storage.format import CRC_KEY, WITNESS_CRC_KEY
from placement.storage.schema import arm_arrays
from placement.storage.stats import STATS_KEY, read_stats, stats_difference, stored_stats

log = logging.getLogger("placement")


def _size(path: Path) -> int:
    """Bytes of the map file, or of every regular file under the map directory (os.scandir: a directory
    entry knows whether it is a file without a second stat, a 5 cm map holds ~30,000 chunk files)."""
    if path.is_file():
        return path.stat().st_size
    total, folders = 0, [str(path)]
    while folders:
        with os.scandir(folders.pop()) as entries:
            for e in entries:
                if e.is_dir(follow_symlinks=False):
                    folders.append(e.path)
                elif e.is_file(follow_symlinks=False):
                    total += e.stat(follow_symlinks=False).st_size
    return total


@click.command(cls=OneLineCommand)
@map_argument
@robot_option
@arm_option
@click.option(
    "--full",
    is_flag=True,
    help="Read and check every chunk of every arm and compare the statistics with the stored ones "
    "(exit 2 naming the arm if they differ).",
)
@standard_options
def info(path: str, robot: str | None, arm: str | None, full: bool, as_json: bool, verbose: int, quiet: bool) -> None:
    """Metadata, fill ratio and value histogram of a map, from the statistics stored when it was saved.

    A map saved without them is read from its chunks, with a `note:` on stderr. --full reads and
    checks every value and witness chunk of every arm and exits 2 naming the array if the stored
    statistics differ."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    check_root(Path(path), store.root)
    stored = arm_arrays(list(store.root.get("arms") or []))  # a torso setting's array is read with its arm
    store.close()
    shown = [arm] if arm else stored
    root = {k: v for k, v in store.root.items() if k != DIGEST_KEY}
    out: dict[str, Any] = {"path": str(path), "size_bytes": _size(Path(path)), "root": root, "arms": {}}
    for a in dict.fromkeys([*shown, *stored]):  # the shown arm first: a wrong --arm fails before the reading
        rmap = open_map(path, a, robot)
        t = rmap.torso
        # one build per torso setting: every setting's map is shown (and with --full read) like the arm's
        views = [rmap] + ([rmap.at_torso(v) for v in t.values if v != t.reference] if t and t.shift is None else [])
        found = []
        for view in views:
            label = a if view is rmap or t is None else f"{a} at {_at(t, view.torso_value)}"
            stats = _stats(view, label, full, quiet)
            meta = {k: v for k, v in view.meta.items() if k not in (CRC_KEY, WITNESS_CRC_KEY, STATS_KEY)}
            found.append({"meta": meta, **stats} | ({} if view is rmap else {"array": view.array}))
        if a in shown:
            out["arms"][a] = found[0] | ({"settings": found[1:]} if len(found) > 1 else {})
    emit(out, as_json, _render_info)


def _stats(view: ReachabilityMap, label: str, full: bool, quiet: bool) -> dict[str, Any]:
    """The statistics of one array as info shows them, with ``stats_from``: "stored" (its metadata's, no
    chunk read) or "read" (every chunk read: ``full``, or a map saved without them, said on stderr);
    MapError naming the array if ``full`` reads other statistics than the stored ones."""
    kept = stored_stats(view.meta)
    if kept is not None and not full:
        return {"stats_from": "stored", "chunks_checked": 0, **kept}
    if kept is None:
        log.info(
            "note: %s: array '%s' has no stored statistics (saved before they were recorded); "
            "computed them by reading every chunk",
            view.path,
            view.array,
        )
    with tqdm(
        total=view.grid.shape[2], desc=f"info {label}", unit="layer", disable=_no_bars(quiet), leave=False
    ) as bar:
        read = read_stats(view.store, view.array, progress=bar.update)  # a torso setting's view: its own array
    if kept is not None:
        differs = stats_difference(kept, read)
        if differs is not None:
            raise MapError(
                f"{view.path}: the stored statistics of array '{view.array}' ({STATS_KEY}) do not match its "
                f"chunks ({differs}); rebuild the map"
            )
    return {"stats_from": "read", **read}


def _no_bars(quiet: bool) -> bool:
    """No progress bars with -q, nor when stderr is not a terminal (a pipe, a log file, a test runner
    that mixes stderr into stdout): what info and check print stays plain."""
    return quiet or not sys.stderr.isatty()


def rank_note(measure: dict[str, Any]) -> str:
    """' on 5 of 6 dimensions' for a map of an arm that spans fewer than 6 (``measure.rank``), else ''."""
    rank = int(measure.get("rank", 6))
    return f" on {rank} of 6 dimensions (the arm's rank)" if rank < 6 else ""


def _at(t: TorsoSettings, value: float | None) -> str:
    """A view's setting in a label: ``torso_2_joint=0.2``, or ``posture 1 (hip=0.5 rad, knee=-0.5 rad)``."""
    return t.describe(float(value or 0.0)) if t.joints else f"{t.joint}={value:g}"


def _posture_at(index: float, posture: dict[str, float]) -> str:
    """A stored posture setting in words: ``posture 1 (hip=0.5, knee=-0.5)`` [m or rad per joint]."""
    return f"posture {round(index)} ({', '.join(f'{j}={x:g}' for j, x in posture.items())})"


def _posture(joints: list[str], units: list[str], values: list[float]) -> str:
    return ", ".join(f"{j}={x:g} {u}" for j, u, x in zip(joints, units, values))


def torso_line(t: dict[str, Any]) -> str:
    """The info line of an arm's torso record (placement/maps/torso.py)."""
    unit = t.get("unit", "m")
    values = ", ".join(f"{v:g}" for v in t["values"])
    if t.get("kind") == "posture":
        shown = "; ".join(
            f"{round(v)} ({_posture(t['joints'], t['units'], t['postures'][round(v)])})" for v in t["values"]
        )
        ref = t["reference_setting"]
        speeds = ", ".join(f"{v:g} {u}/s" for v, u in zip(t["velocities"], t["units"]))
        return (
            f"    torso {'+'.join(t['joints'])}: postures {shown}, one build per posture (the arm's own at "
            f"{_posture(t['joints'], t['units'], t['postures'][ref])}), {speeds}"
        )
    if t.get("shift") is None:
        return (
            f"    torso {t['joint']}: settings {values} {unit}, one build per setting (the arm's own at "
            f"{t['reference']:g} {unit}), {t['velocity']:g} {unit}/s"
        )
    shift = ", ".join(f"{v:.6g}" for v in t["shift"])
    return (
        f"    torso {t['joint']}: settings {values} m (built at {t['reference']:g} m; the map moves by "
        f"[{shift}] m per m of lift), {t['velocity']:g} m/s"
    )


#: how info's text says where an array's statistics came from (``stats_from``)
_FROM = {"stored": "stored statistics", "read": "read from every chunk"}


def _fill_lines(v: dict[str, Any], indent: str = "    ") -> list[str]:
    h = v["value"]["histogram"]
    return [
        f"{indent}filled {v['filled_cells']} of {v['cells']} cells ({100 * v['fill_ratio']:.2f} %), "
        f"max {v['value']['max']:.4f}, mean {v['value']['mean']:.4f} ({_FROM[v['stats_from']]})",
        f"{indent}histogram: "
        + ", ".join(f"[{lo:g}, {hi:g}): {c}" for lo, hi, c in zip(h["edges"], h["edges"][1:], h["counts"])),
    ]


def _render_info(d: dict[str, Any]) -> str:
    r = d["root"]
    lines = [f"{d['path']}  ({d['size_bytes'] / 1e6:.1f} MB)  robot {r.get('robot')}  base {r.get('base_frame')}"]
    for a, v in d["arms"].items():
        m = v["meta"]
        g = m["grid"]
        lines.append(
            f"  arm {a}: tip {m['tip_frame']}, grid {g['shape']} at {g['resolution']} m, "
            f"{m['measure']['index']}{rank_note(m['measure'])}, {m['samples']} samples (seed {m['seed']}), "
            f"built in {m['build_time_s']} s"
        )
        if "torso" in m:
            lines.append(torso_line(m["torso"]))
        lines += _fill_lines(v)
        for sv in v.get("settings", []):
            sm, st = sv["meta"], sv["meta"]["setting"]
            at = f"{st['joint']} = {st['value']:g} {st.get('unit', 'm')}"
            if "posture" in st:  # a posture of several torso joints: its index and every joint's value
                at = _posture_at(st["value"], st["posture"])
            lines.append(
                f"    setting {at} (array {sv['array']}): built, "
                f"grid {sm['grid']['shape']}, {sm['samples']} samples (seed {sm['seed']}) in {sm['build_time_s']} s"
            )
            lines += _fill_lines(sv, "      ")
    return "\n".join(lines)


@click.command(cls=OneLineCommand)
@map_argument
@robot_option
@arm_option
@samples_option(
    count_type(1, MAX_CHECK_SAMPLES),
    200,
    f"IK checks per class (reachable / unreachable) [count, 1 to {MAX_CHECK_SAMPLES:,}; default 200].",
)
@click.option("--seed", type=SEED, default=0, help="Seed of the cell draws and IK restarts.")
@standard_options
def check(
    path: str, robot: str | None, arm: str | None, samples: int, seed: int, as_json: bool, verbose: int, quiet: bool
) -> None:
    """Accuracy of a map against inverse kinematics on random poses.

    Pose-level precision (uniform poses inside reachable cells, IK to 1 cm / 0.05 rad from the cell's
    witness) and recall (uniform in-reach cells an independent IK reaches), with 95 % intervals and
    counts, and the cell-level counts beside them. Every chunk is read and checked first; a map built
    once per torso setting is checked per setting, the torso held there."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    arms = [arm] if arm else arm_arrays(list(store.root.get("arms") or []))
    out: dict[str, Any] = {"path": str(path), "arms": {}}
    held = load_robot(robot or store.root.get("preset") or store.root["robot"])
    for a in arms:
        log.info("arm %s: reading and checking every chunk", a)
        rmap = open_map(path, a, held).load()
        doc = out["arms"][a] = _check_arm(held, rmap, a, samples, seed, quiet)
        t = rmap.torso
        if t is None:
            continue
        doc["torso"] = {
            "joint": t.joint,
            "kind": t.kind,
            "unit": t.unit,
            "reference": t.reference,
            "values": list(t.values),
            "checked": "reference" if t.kind == "shifted" else "every setting",
        }
        if t.joints:
            doc["torso"]["posture"] = t.held(t.reference)
        if t.kind == "shifted":  # the same array moved with the lift: the reference's check is every setting's
            continue
        doc["settings"] = []
        for v in t.values:
            if v == t.reference:
                continue
            log.info("arm %s at %s = %g %s: reading and checking every chunk", a, t.joint, v, t.unit)
            view = rmap.at_torso(v).load()
            one = _check_arm(held.with_fixed(t.held(v)), view, f"{a} {_at(t, v)}", samples, seed, quiet)
            setting = {"joint": t.joint, "value": v, "unit": t.unit, "array": view.array}
            if t.joints:
                setting["posture"] = t.held(v)
            doc["settings"].append({"setting": setting} | one)
    emit(out, as_json, _render_check)


def _check_arm(robot: Robot, rmap: ReachabilityMap, arm: str, samples: int, seed: int, quiet: bool) -> dict[str, Any]:
    """:func:`check_map` of one arm with a bar for its cell-level IK solves and one for the pose-level
    ones (:func:`pose_metrics`, which check_map runs without a progress hook): the same document."""

    def bar(what: str) -> tqdm[Any]:
        return tqdm(total=1, desc=f"check {arm}: {what}", unit="IK", disable=_no_bars(quiet), leave=False)

    def ticker(b: tqdm[Any]) -> Callable[[int, int], None]:
        def tick(done: int, total: int) -> None:
            b.total = total
            b.update(done - b.n)

        return tick

    with bar("cells") as b:
        doc = check_map(robot, rmap, samples=samples, seed=seed, pose_level=False, progress=ticker(b))
    with bar("poses") as b:
        doc["pose_level"] = pose_metrics(robot, rmap, samples, seed, doc["threshold"], progress=ticker(b))
    doc["time_s"] = round(doc["time_s"] + doc["pose_level"]["time_s"], 4)
    return doc


def _rate(x: float | None, ci: Sequence[float]) -> str:
    return "n/a" if x is None else f"{100 * x:.1f} % (95 % CI {100 * ci[0]:.1f}-{100 * ci[1]:.1f})"


def _check_lines(head: str, r: dict[str, Any]) -> list[str]:
    """The two lines of one map's check (``head`` names it)."""
    p = r["pose_level"]
    return [
        f"{head}: pose-level (IK to {p['pos_tol_m']} m, {p['rot_tol_rad']} rad): "
        f"precision {_rate(p['precision'], p['precision_ci95'])} of {p['precision_poses']} poses in "
        f"reachable cells; recall {_rate(p['recall'], p['recall_ci95'])} of {p['recall_cells']} "
        f"IK-reachable cells ({p['recall_draws']} drawn in reach)",
        "  cell-level (one-cell tolerance): "
        + ", ".join(f"{k} {v}" for k, v in r.items() if not isinstance(v, (dict, list))),
    ]


def _render_check(d: dict[str, Any]) -> str:
    lines = []
    for a, r in d["arms"].items():
        t = r.get("torso")
        if t is None:
            lines += _check_lines(f"{d['path']} arm {a}", r)
            continue
        unit = t["unit"]
        values = ", ".join(f"{v:g}" for v in t["values"])
        at = f"{t['joint']} = {t['reference']:g} {unit}"
        if "posture" in t:
            at = _posture_at(t["reference"], t["posture"])
        lines += _check_lines(f"{d['path']} arm {a} at {at} (reference)", r)
        if t["kind"] == "shifted":
            lines.append(
                f"  torso {t['joint']}: settings {values} {unit} share this map moved with the lift (a shifted "
                "map): the reference's check stands for every setting"
            )
        for sv in r.get("settings", []):
            st = sv["setting"]
            at = f"{st['joint']} = {st['value']:g} {unit}"
            if "posture" in st:
                at = _posture_at(st["value"], st["posture"])
            head = f"{d['path']} arm {a} at {at} (array {st['array']})"
            lines += _check_lines(head, sv)
    return "\n".join(lines)


@click.command(cls=OneLineCommand)
@map_argument
@robot_option
@arm_option
@samples_option(
    count_type(1, 10**12), None, "Check this many reached cells drawn at random [count] (default: all; ~2 us per cell)."
)
@click.option("--seed", type=SEED, default=0, help="Seed of the --samples draw.")
@standard_options
def verify(
    path: str,
    robot: str | None,
    arm: str | None,
    samples: int | None,
    seed: int,
    as_json: bool,
    verbose: int,
    quiet: bool,
) -> None:
    """Recompute every stored value (or --samples random reached cells) from its witness, bitwise.

    Exit 1 with one line per arm that has mismatches (how many, the first few); about 2 us per cell
    on 2 cores, progress on stderr."""
    setup_logging(verbose, quiet)
    store = open_store(path)
    check_root(Path(path), store.root)
    arms = [arm] if arm else arm_arrays(list(store.root.get("arms") or []))
    store.close()
    out: dict[str, Any] = {"path": str(path), "arms": {}}
    for a in arms:
        rmap = open_map(path, a, robot)
        t = rmap.torso
        # one build per torso setting: each setting's map is recomputed with the robot at that setting
        views = [rmap] + ([rmap.at_torso(v) for v in t.values if v != t.reference] if t and t.shift is None else [])
        for view in views:
            assert view.robot is not None  # open_map loads the robot the map names when none is given
            with EtaBar(
                total=1, desc=f"verify {view.array}", unit="cell", unit_scale=True, disable=quiet, leave=False
            ) as bar:

                def tick(done: int, total: int) -> None:
                    bar.total = total
                    bar.update(done - bar.n)

                out["arms"][view.array] = verify_witnesses(view.robot, view, sample=samples, seed=seed, progress=tick)
    emit(out, as_json, _render_verify)
    if any(r["mismatches"] for r in out["arms"].values()):
        raise SystemExit(1)


def _render_verify(d: dict[str, Any]) -> str:
    lines = []
    for a, r in d["arms"].items():
        head = (
            f"{d['path']} arm {a}: {r['cells_checked']} of {r['cells_reached']} reached cells recomputed "
            f"from their witnesses in {r['time_s']} s"
        )
        if not r["mismatches"]:
            lines.append(head + ": all equal (bitwise)")
        else:
            shown = "; ".join(
                f"cell {f['cell']} (witness {f['witness']}): stored {f['stored']}, recomputed {f['recomputed']}"
                for f in r["first"][:3]
            )
            lines.append(f"{head}: {r['mismatches']} MISMATCH, first: {shown}")
    return "\n".join(lines)
