"""Importing the package and asking the command line for help load no numba, zarr or pinocchio: the
public names and the commands are imported when first used. Checked in fresh processes (this one has
imported everything long before), by the modules loaded, not by time."""

from __future__ import annotations

import ast
import importlib
import json
import subprocess
import sys
from pathlib import Path

import click
import pytest

import placement
from placement.cli.lazy import LazyGroup, load
from placement.cli.main import cli

ROOT = Path(__file__).resolve().parents[1]

#: what ``import placement`` or a listing of commands must not load (about 1.5 s together)
HEAVY = ("numba", "zarr", "pinocchio", "h5py", "coal", "matplotlib", "placement.planning", "placement.maps")


def _fresh(code: str) -> dict[str, object]:
    """Run ``code`` in a fresh interpreter; it leaves its findings in the dict ``out``, returned with
    ``heavy``: the modules of :data:`HEAVY` (or inside them) loaded by the end."""
    script = (
        f"import json, sys\nout = {{}}\n{code}\n"
        f"out['heavy'] = sorted(m for m in sys.modules if any(m == h or m.startswith(h + '.') for h in {HEAVY!r}))\n"
        "print(json.dumps(out))"
    )
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr
    found: dict[str, object] = json.loads(proc.stdout.splitlines()[-1])
    return found


def test_import_placement_loads_nothing_heavy_until_a_name_is_used():
    out = _fresh(
        "import placement\n"
        "out['before'] = sorted(m for m in ('numba', 'zarr', 'pinocchio', 'placement.planning') if m in sys.modules)\n"
        "planner = placement.Planner\n"
        "from placement.planning.planner import Planner\n"
        "out['same'] = planner is Planner"
    )
    assert out["before"] == []
    assert out["same"] is True
    assert "numba" in out["heavy"]  # the planner's kernels came with it: the check sees numba when it is there


def test_light_names_are_there_at_once():
    out = _fresh(
        "import placement\nfrom placement.errors import MapError\nfrom placement.version import __version__\n"
        "out['ok'] = placement.MapError is MapError and placement.__version__ == __version__"
    )
    assert out == {"ok": True, "heavy": []}


def _stub_names() -> dict[str, str]:
    """name -> module of every import in placement/__init__.pyi: the one list of public names, read by
    the lazy loader and by type checkers alike."""
    tree = ast.parse((ROOT / "placement" / "__init__.pyi").read_text())
    return {
        a.asname or a.name: "placement" + ("." + node.module if node.module else "")
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for a in node.names
    }


@pytest.mark.parametrize("name", sorted(_stub_names()))
def test_every_lazy_name_is_what_type_checkers_see(name):
    module = _stub_names()[name]
    assert getattr(placement, name) is getattr(importlib.import_module(module), name)


def test_the_stub_lists_every_public_name_once():
    assert sorted(_stub_names()) == sorted(placement.__all__)
    assert placement.__all__ == sorted(placement.__all__)


def test_dir_lists_the_public_names_and_an_unknown_name_fails():
    assert set(placement.__all__) <= set(dir(placement))
    with pytest.raises(AttributeError, match="no_such_name"):
        placement.no_such_name  # noqa: B018


@pytest.mark.parametrize(
    "args", [[], ["maps"], ["scenes"], ["robots"], ["query"], ["view"]], ids=lambda a: " ".join(["placement", *a])
)
def test_help_and_group_listings_load_nothing_heavy(args):
    out = _fresh(
        "from click.testing import CliRunner\nfrom placement.cli.main import cli\n"
        f"r = CliRunner().invoke(cli, {args!r} + ['--help'])\nout['code'] = r.exit_code"
    )
    assert out == {"code": 0, "heavy": []}


def test_a_mistyped_command_loads_nothing_heavy():
    out = _fresh(
        "from click.testing import CliRunner\nfrom placement.cli.main import cli\n"
        "r = CliRunner().invoke(cli, ['maps', 'bulid'])\nout['code'] = r.exit_code\nout['err'] = r.stderr"
    )
    assert out["code"] == 2
    assert "No such command 'bulid'" in str(out["err"])
    assert out["heavy"] == []


def _groups() -> dict[str, LazyGroup]:
    """Every lazy group of the command line, by its command path (loads every command)."""
    found = {"placement": cli}
    for path, group in list(found.items()):
        for name, target in group.lazy.items():
            command = load(target)
            if isinstance(command, LazyGroup):
                found[f"{path} {name}"] = command
    return found


@pytest.mark.parametrize("path", list(_groups()))
def test_lazy_targets_are_the_commands_of_their_names(path):
    for name, target in _groups()[path].lazy.items():
        assert load(target).name == name, f"{path}: {name} -> {target} is another command"


@pytest.mark.parametrize("path", list(_groups()))
def test_the_listing_from_docstrings_is_clicks_listing_of_the_loaded_commands(path):
    """A fresh process lists the commands from their docstrings; click lists the loaded commands here
    (this process imported them all): the two must read the same."""
    args = path.split()[1:] + ["--help"]
    fresh = _fresh(
        "from click.testing import CliRunner\nfrom placement.cli.main import cli\n"
        f"out['help'] = CliRunner().invoke(cli, {args!r}, terminal_width=80).output"
    )
    group = _groups()[path]
    loaded = click.Group(group.name, commands={n: load(t) for n, t in group.lazy.items()})
    ctx = click.Context(loaded, info_name=group.name, terminal_width=80)
    formatter = ctx.make_formatter()
    loaded.format_commands(ctx, formatter)
    reference = formatter.getvalue()
    assert "Commands:" in reference
    assert reference in str(fresh["help"])


def test_the_light_method_names_are_the_registrys():
    from placement.method_names import DEFAULT_METHOD, METHOD_NAMES
    from placement.planning.methods import registry

    assert METHOD_NAMES == tuple(registry.METHODS) and DEFAULT_METHOD == registry.DEFAULT_METHOD
    assert DEFAULT_METHOD in METHOD_NAMES
