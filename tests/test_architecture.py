"""The codebase's own rules (developers' guide), checked on the source so they cannot drift.

* the direction of dependencies: one package per half and shared concept, each importing only the packages
  of its row in :data:`ALLOWED` (every import counts: top level, function-local and ``TYPE_CHECKING``);
* no import cycle between modules, nor between packages;
* nothing imports the CLI; plotting and viewers are never imported by the algorithms; opening a map does not
  import the builder;
* no private name (leading underscore) of one module used from another.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "placement"


def _modules(*folders: str) -> list[Path]:
    return sorted(p for f in folders for p in (ROOT / f).rglob("*.py") if "__pycache__" not in p.parts)


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@functools.cache
def _imports(path: Path) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """(absolute module, imported names) of every import in the file, relative ones resolved (parsed
    once per run: every module is read by several tests)."""
    tree = ast.parse(path.read_text())
    package = _module_name(path) if path.name == "__init__.py" else _module_name(path).rsplit(".", 1)[0]
    out: list[tuple[str, tuple[str, ...]]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, ()) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            out.append((base, tuple(a.name for a in node.names)))
    return tuple(out)


MODULES = {_module_name(p): p for p in _modules("placement")}


def _targets(path: Path) -> set[str]:
    """The modules of placement that ``path`` imports: ``from a.b import c`` is a.b.c when that is a module,
    else a.b; a name that is no module is cut back to the nearest module above it."""
    out = set()
    for module, names in _imports(path):
        if not module.startswith("placement"):
            continue
        for name in [f"{module}.{n}" for n in names] or [module]:
            while name not in MODULES and "." in name:
                name = name.rsplit(".", 1)[0]
            if name in MODULES:
                out.add(name)
    return out - {_module_name(path)}


# -- the layers --------------------------------------------------------------------------------------------
# kernels (numba) <- robots (presets), storage <- kinematics <- scene <- collision <- maps (offline) and
# planning (online; it opens maps) <- evaluation, viewer, robots.onboarding <- cli. "placement" is the package's
# own facade (placement/__init__.py). The shared helpers at the top have their own rows.

NOTHING: frozenset[str] = frozenset()
HELPERS = {
    "placement.errors",
    "placement.progress",
    "placement.validation",
    "placement.simplicity",
    "placement.version",
    "placement.method_names",
    "placement.process_env",
    "placement.compile_clock",
}
BELOW_ROBOTS = {"placement.kernels", *HELPERS}
BELOW_KINEMATICS = {"placement.robots", "placement.storage", *BELOW_ROBOTS}
BELOW_SCENE = {"placement.kinematics", *BELOW_KINEMATICS}
BELOW_COLLISION = {"placement.scene", *BELOW_SCENE}
BELOW_MAPS = {"placement.collision", *BELOW_COLLISION}
BELOW_APPS = {"placement", "placement.planning", "placement.maps", "placement.plotting", *BELOW_MAPS}

#: package -> the packages it may import (its own always)
ALLOWED: dict[str, set[str] | frozenset[str]] = {
    "placement.errors": NOTHING,
    "placement.version": NOTHING,
    "placement.validation": NOTHING,
    "placement.simplicity": NOTHING,
    "placement.method_names": NOTHING,
    "placement.process_env": NOTHING,
    "placement.compile_clock": NOTHING,
    "placement.progress": {"placement.errors"},
    "placement.kernels": {"placement.errors"},
    "placement.robots": BELOW_ROBOTS,
    "placement.storage": {"placement.robots", *BELOW_ROBOTS},
    "placement.kinematics": BELOW_KINEMATICS,
    "placement.collision": BELOW_COLLISION,
    "placement.scene": BELOW_SCENE,
    "placement.maps": BELOW_MAPS,
    "placement.planning": {"placement.maps", *BELOW_MAPS},
    "placement": {"placement.maps", "placement.planning", *BELOW_MAPS},
    "placement.plotting": {"placement.maps", "placement.planning", *BELOW_MAPS},
    "placement.evaluation": BELOW_APPS,
    "placement.viewer": BELOW_APPS,
    "placement.robots.onboarding": BELOW_APPS,
    "placement.ros": {*BELOW_APPS, "placement.evaluation"},
    "placement.warmup": {*BELOW_APPS, "placement.evaluation", "placement.viewer", "placement.robots.onboarding"},
    "placement.cli": {*BELOW_APPS, "placement.evaluation", "placement.viewer", "placement.robots.onboarding"}
    | {"placement.warmup", "placement.ros"},
}
#: the only packages that may import plotting, and warmup
PLOTTING_USERS = {"placement.cli", "placement.evaluation", "placement.viewer", "placement.robots.onboarding"}
PLOTTING_USERS |= {"placement.warmup"}
WARMUP_USERS = {"placement.cli"}

#: Imports that still go the wrong way, each waiting for a move (importer module, imported module), with a comment
#: saying where its code belongs. Empty: every import follows the layers; an entry added here must be taken out
#: again once its code moves.
PENDING: set[tuple[str, str]] = set()


def _package(module: str) -> str:
    """The row of :data:`ALLOWED` that ``module`` belongs to (the longest matching package)."""
    rows = [p for p in ALLOWED if module == p or module.startswith(p + ".")]
    assert rows, f"{module} belongs to no row of ALLOWED: give its package a row"
    return max(rows, key=len)


@pytest.mark.parametrize("path", _modules("placement"), ids=lambda p: str(p.relative_to(ROOT)))
def test_dependencies_follow_the_layers(path):
    name = _module_name(path)
    own = _package(name)
    for target in sorted(_targets(path)):
        other = _package(target)
        if other == own or (name, target) in PENDING:
            continue
        assert other in ALLOWED[own], f"{name} imports {target}: {own} may import only {sorted(ALLOWED[own])}"
        if other == "placement.plotting":
            assert own in PLOTTING_USERS, f"{name} imports plotting ({target})"
        if other == "placement.warmup":
            assert own in WARMUP_USERS, f"{name} imports warmup ({target})"


@pytest.mark.slow
def test_pending_exceptions_are_still_needed():
    """An exception whose import is gone is taken out of PENDING, so the list only shrinks."""
    edges = {(name, t) for name, path in MODULES.items() for t in _targets(path)}
    assert PENDING <= edges, f"imports no longer there: {sorted(PENDING - edges)}"


@pytest.mark.parametrize("path", _modules("placement"), ids=lambda p: str(p.relative_to(ROOT)))
def test_nothing_imports_the_cli_and_algorithms_no_viewer(path):
    name = _module_name(path)
    for module, _ in _imports(path):
        if not name.startswith("placement.cli"):
            assert not module.startswith("placement.cli"), f"{name} imports the CLI ({module})"
        if not name.startswith(("placement.cli", "placement.ros")):
            assert not module.startswith("placement.ros"), f"{name} imports the ROS node ({module})"
            assert not module.startswith("rclpy"), f"{name} imports rclpy ({module})"
        if not name.startswith(("placement.cli", "placement.plotting", "placement.viewer")):
            assert not module.startswith("viser"), f"{name} imports a viewer ({module})"
        if name.startswith(("placement.planning", "placement.maps", "placement.kernels", "placement.storage")):
            assert not module.startswith(("matplotlib", "viser")), f"{name} imports {module}"
        if name == "placement.maps.rmap":  # opening a map needs none of the builder
            heavy = ("placement.maps.build", "placement.maps.selfcollision", "tqdm")
            assert not module.startswith(heavy), f"{name} imports {module}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


@pytest.mark.slow
def test_no_import_cycle_between_modules():
    graph = {name: {t for t in _targets(path) if (name, t) not in PENDING} for name, path in MODULES.items()}
    assert _cycles(graph) == []


@pytest.mark.slow
def test_no_import_cycle_between_packages():
    graph: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        own = _package(name)
        graph.setdefault(own, set())
        for t in _targets(path):
            if (name, t) not in PENDING and _package(t) != own:
                graph[own].add(_package(t))
    assert _cycles(graph) == []


@pytest.mark.slow
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


#: standard library names that begin with an underscore yet are documented public API
PUBLIC_UNDERSCORED = {("os", "_exit")}


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
            if isinstance(owner, ast.Name) and (owner.id, node.attr) in PUBLIC_UNDERSCORED:
                continue
            found.append(f"line {node.lineno}: .{node.attr}")
    return found


@pytest.mark.slow
@pytest.mark.parametrize("path", _modules("placement", "tools"), ids=lambda p: str(p.relative_to(ROOT)))
def test_no_private_member_is_used_from_another_module(path):
    assert _private_uses(path) == []


# -- the planning concepts -----------------------------------------------------------------------------------
#: the concept packages of placement.planning, each used from outside through its front (its __init__)
CONCEPTS = ("world", "verification", "problems", "program", "methods")


def _concept(module: str) -> str:
    """The node of ``module`` in planning's own graph: its concept package, or the module itself."""
    parts = module.split(".")
    if len(parts) >= 3 and parts[:2] == ["placement", "planning"] and parts[2] in CONCEPTS:
        return ".".join(parts[:3])
    return module


@pytest.mark.parametrize("path", _modules("placement"), ids=lambda p: str(p.relative_to(ROOT)))
def test_a_planning_concept_is_used_through_its_front(path):
    name = _module_name(path)
    for module, _ in _imports(path):
        parts = module.split(".")
        if len(parts) > 3 and parts[:2] == ["placement", "planning"] and parts[2] in CONCEPTS:
            front = ".".join(parts[:3])
            assert _concept(name) == front, f"{name} imports {module}: use its front {front}"


def test_no_cycle_between_planning_concepts():
    graph: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        if not name.startswith("placement.planning"):
            continue
        own = _concept(name)
        graph.setdefault(own, set())
        for t in _targets(path):
            if t.startswith("placement.planning") and _concept(t) != own and t != "placement.planning":
                graph[own].add(_concept(t))
    assert _cycles(graph) == []


def _windows(path: Path, size: int) -> set[tuple[str, ...]]:
    """Every run of ``size`` consecutive code lines of ``path`` (stripped; blank lines, comments,
    imports and docstrings left out), as tuples."""
    tree = ast.parse(path.read_text())
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            skip.update(range(node.lineno, (node.end_lineno or node.lineno) + 1))
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            doc = body[0]
            if isinstance(doc.value, ast.Constant) and isinstance(doc.value.value, str):
                skip.update(range(doc.lineno, (doc.end_lineno or doc.lineno) + 1))
    lines = [
        ln.strip()
        for i, ln in enumerate(path.read_text().splitlines(), 1)
        if i not in skip and ln.strip() and not ln.strip().startswith("#")
    ]
    # a closing bracket or a lone keyword says nothing of its own
    lines = [ln for ln in lines if len(ln) > 3]
    return {tuple(lines[i : i + size]) for i in range(len(lines) - size + 1)}


def test_no_code_is_copied_between_planning_modules():
    """Six consecutive code lines in two modules of placement.planning are one concept in two places:
    keep it once (a base class, a function) and use it from both."""
    seen: dict[tuple[str, ...], str] = {}
    copies = []
    for name, path in MODULES.items():
        if not name.startswith("placement.planning"):
            continue
        for window in _windows(path, 6):
            other = seen.setdefault(window, name)
            if other != name:
                copies.append(f"{other} and {name}: {window[0]!r} ...")
    assert copies == []
