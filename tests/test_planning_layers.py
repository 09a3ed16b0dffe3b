"""The planning package's own structure: its modules import each other without a cycle (imports
under ``if TYPE_CHECKING:`` included), and no stage but the planner sees the planner."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLANNING = ROOT / "placement" / "planning"
PACKAGE = "placement.planning"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def planning_modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PLANNING.rglob("*.py")) if "__pycache__" not in p.parts}


def imported(path: Path, modules: set[str]) -> set[str]:
    """The planning modules ``path`` imports (anywhere in the file, TYPE_CHECKING blocks and
    function bodies included): ``from a.b import c`` names module a.b.c when that is a module."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [
                f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module for a in node.names
            ]
        else:
            continue
        out |= {n for n in names if n in modules}
    return out


def import_graph() -> dict[str, set[str]]:
    modules = planning_modules()
    return {name: imported(path, set(modules)) - {name} for name, path in modules.items()}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """A cycle of ``graph`` as a list of nodes (first == last), or None when it is acyclic."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_the_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]


def test_planning_modules_import_each_other_without_a_cycle():
    graph = import_graph()
    assert f"{PACKAGE}.planner" in graph and f"{PACKAGE}.methods.stepwise" in graph
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_only_the_planner_module_and_the_package_import_the_planner():
    graph = import_graph()
    users = sorted(m for m, deps in graph.items() if f"{PACKAGE}.planner" in deps)
    assert users == [PACKAGE], users


def test_no_stage_takes_a_planner():
    """No function of a planning module but planner.py has a parameter annotated ``Planner``."""
    for name, path in planning_modules().items():
        if name == f"{PACKAGE}.planner":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for arg in [*node.args.args, *node.args.kwonlyargs, *node.args.posonlyargs]:
                    text = ast.unparse(arg.annotation) if arg.annotation is not None else ""
                    assert "Planner" not in text.replace("PlannerConfig", ""), f"{name}.{node.name}({arg.arg}: {text})"
                    assert arg.arg != "planner", f"{name}.{node.name} takes a planner"
