"""The codebase's own rules (developers' guide, issue 11), checked on the source so they cannot drift.

* the direction of dependencies: kernels <- storage <- planning <- CLI; nothing imports the CLI;
  plotting and viewers are never imported by the algorithms; opening a map does not import the builder;
* no module over 400 lines (generated ones included);
* no private name (leading underscore) of one module used from another.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "placement"
MAX_LINES = 400


def _modules(*folders: str) -> list[Path]:
    return sorted(p for f in folders for p in (ROOT / f).rglob("*.py") if "__pycache__" not in p.parts)


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[str, list[str]]]:
    """(absolute module, imported names) of every import in the file, relative ones resolved."""
    tree = ast.parse(path.read_text())
    package = _module_name(path) if path.name == "__init__.py" else _module_name(path).rsplit(".", 1)[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            out.append((base, [a.name for a in node.names]))
    return out


# (importer prefix, forbidden import prefixes)
LAYERS = [
    (
        "placement.kernels",
        (
            "placement.storage",
            "placement.planning",
            "placement.cli",
            "placement.robots",
            "placement.evaluation",
            "placement.plotting",
            "placement.maps.build",
            "placement.maps.rmap",
        ),
    ),
    (
        "placement.storage",
        ("placement.planning", "placement.cli", "placement.evaluation", "placement.maps.build", "placement.plotting"),
    ),
    (
        "placement.maps.rmap",
        ("placement.maps.build", "placement.planning", "placement.cli", "tqdm", "placement.maps.selfcollision"),
    ),
    (
        "placement.planning",
        ("placement.cli", "placement.evaluation", "placement.plotting", "placement.viewer", "matplotlib", "viser"),
    ),
    ("placement.evaluation", ("placement.cli",)),
    ("placement.robots", ("placement.planning", "placement.cli", "placement.storage")),
]


@pytest.mark.parametrize("path", _modules("placement"), ids=lambda p: str(p.relative_to(ROOT)))
def test_dependencies_point_one_way(path):
    name = _module_name(path)
    for module, _ in _imports(path):
        if not name.startswith("placement.cli"):
            assert not module.startswith("placement.cli"), f"{name} imports the CLI ({module})"
        if not name.startswith(("placement.cli", "placement.plotting", "placement.viewer")):
            assert not module.startswith("viser"), f"{name} imports a viewer ({module})"
        for prefix, forbidden in LAYERS:
            if name == prefix or name.startswith(prefix + "."):
                bad = [f for f in forbidden if module == f or module.startswith(f + ".")]
                assert not bad, f"{name} imports {module}, against the layering"


def test_opening_a_map_does_not_import_the_builder():
    import subprocess
    import sys

    code = (
        "import sys, placement; placement.open_map; placement.plan; "
        "print(sorted(m for m in ('placement.maps.build', 'tqdm', 'placement.maps.selfcollision', 'placement.viewer', "
        "'viser') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("path", _modules("placement", "tests", "tools"), ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_are_small(path):
    n = len(path.read_text().splitlines())
    assert n <= MAX_LINES, f"{path.relative_to(ROOT)} has {n} lines (at most {MAX_LINES}): split it by concept"


def _private_uses(path: Path) -> list[str]:
    tree = ast.parse(path.read_text())
    found = []
    for module, names in _imports(path):
        if module.startswith("placement"):
            found += [f"imports {module}.{n}" for n in names if n.startswith("_") and not n.startswith("__")]
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            owner = node.value
            if isinstance(owner, ast.Name) and owner.id in ("self", "cls", "new"):
                continue  # an object's own members (``new``: a copy made inside the class)
            found.append(f"line {node.lineno}: .{node.attr}")
    return found


@pytest.mark.parametrize("path", _modules("placement", "tools"), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_member_is_used_from_another_module(path):
    assert _private_uses(path) == []
