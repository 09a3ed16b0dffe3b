"""Set-up that holds outside make: declared and pinned dependencies, the kernels' cache found by every
entry point, and the closing skip summary of a test run."""

from __future__ import annotations

import ast
import importlib.metadata
import importlib.util
import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _name(requirement: str) -> str:
    """Normalised distribution name of a requirement string ("dask[distributed]>=1" -> "dask")."""
    return re.sub(r"[-_.]+", "-", re.match(r"\s*([A-Za-z0-9._-]+)", requirement).group(1)).lower()


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(x) for x in re.findall(r"\d+", text)[:4])


def _project() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def _declared() -> dict[str, list[str]]:
    """distribution -> its requirement strings in dependencies and every extra."""
    project = _project()
    out: dict[str, list[str]] = {}
    for req in project["dependencies"] + [r for reqs in project["optional-dependencies"].values() for r in reqs]:
        out.setdefault(_name(req), []).append(req)
    return out


def _imported_top_modules() -> set[str]:
    """Top-level modules imported anywhere in placement/, tools/ and tests/ (absolute imports)."""
    found = set()
    for folder in ("placement", "tools", "tests"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.Import):
                    found.update(a.name.split(".")[0] for a in node.names)
                elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                    found.add(node.module.split(".")[0])
    return found


def _owners(modules) -> dict[str, list[str]]:
    """module -> distributions installing it; by the files each distribution records, so that modules
    installed under another prefix (cmeel's pin and coal: site-packages/cmeel.prefix/...) are found too."""
    owners = {m: list(d) for m, d in importlib.metadata.packages_distributions().items()}
    wanted = {}
    for m in modules:
        if m not in owners:
            spec = importlib.util.find_spec(m)
            if spec and spec.origin:
                wanted[os.path.realpath(spec.origin)] = m
    tails = {"/".join(Path(path).parts[-2:]): path for path in wanted}  # "pinocchio/__init__.py"
    for dist in importlib.metadata.distributions() if wanted else ():
        for file in dist.files or ():
            path = tails.get("/".join(file.parts[-2:]))
            if path and os.path.realpath(dist.locate_file(file)) == path:
                owners.setdefault(wanted[path], []).append(dist.metadata["Name"])
    return owners


@pytest.mark.slow
def test_every_imported_third_party_module_is_declared():
    local = {p.stem for p in (ROOT / "tests").glob("*.py")} | {p.stem for p in (ROOT / "tools").glob("*.py")}
    local |= {"placement", "support"}  # tests/support: the helpers the test files share
    third_party = sorted(
        m for m in _imported_top_modules() if m not in sys.stdlib_module_names and m not in local and m != "__future__"
    )
    owners = _owners(third_party)
    declared = set(_declared())
    missing = {m: owners.get(m) for m in third_party if not {_name(d) for d in owners.get(m, [])} & declared}
    assert not missing, f"imported but not declared in pyproject.toml (module: distributions): {missing}"
    # the three the issue named, by their PyPI names
    assert {"coal", "trimesh", "pillow"} <= declared


def test_constraints_pin_every_declared_dependency_within_its_bounds():
    pins = {}
    for line in (ROOT / "constraints.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            assert "==" in line and "@" not in line, f"constraints.txt: not a plain pin: {line!r}"
            name, version = line.split("==")
            pins[_name(name)] = version.strip()
    for name, reqs in _declared().items():
        assert name in pins, f"{name} is declared in pyproject.toml but not pinned in constraints.txt"
        for req in reqs:
            lower = re.search(r">=\s*([0-9][0-9.a-z]*)", req)
            assert lower, f"{req!r}: no tested lower bound (>=)"
            assert _version(pins[name]) >= _version(lower.group(1)), f"{req} but constraints pin {pins[name]}"
    # the installed environment is the pinned one (the bounds were tested with these versions)
    for name in ("numpy", "numba", "pin", "coal", "zarr"):
        assert importlib.metadata.version(name) == pins[name]


def test_make_install_and_ci_use_the_constraints():
    makefile = (ROOT / "Makefile").read_text()
    assert re.search(r"pip install .*-c constraints\.txt -e '\.\[test,dev,docs\]'", makefile)
    assert re.search(r"\.venv/installed:.*constraints\.txt", makefile)
    ci = (ROOT / ".ci/run").read_text()
    assert "make lint" in ci and "make test" in ci and ci.index("make lint") < ci.index("make test")


def test_numba_cache_defaults_to_the_environment_make_install_warms():
    if sys.prefix == sys.base_prefix:
        pytest.skip("not in a virtual environment: the kernels use numba's user-wide cache")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    # the kernels set numba's cache directory when they are imported, and leave the environment alone
    code = (
        "import os, placement, placement.kernels, numba; "
        "print(os.environ.get('NUMBA_CACHE_DIR')); print(numba.config.CACHE_DIR)"
    )
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    got, kernels = out.stdout.split("\n")[:2]
    assert got == "None"
    assert kernels.startswith(os.path.join(sys.prefix, "numba-cache") + os.sep)
    # the Makefile's warm-up writes to the same place for the project's .venv
    if Path(sys.prefix).resolve() == (ROOT / ".venv").resolve():
        assert "NUMBA_CACHE_DIR ?= $(CURDIR)/.venv/numba-cache" in (ROOT / "Makefile").read_text()


def test_numba_cache_dir_set_by_the_user_is_kept():
    import numba

    import placement.kernels  # noqa: F401  (sets numba's cache dir from the variable)

    assert os.environ["NUMBA_CACHE_DIR"]  # set by this run (Makefile, conftest or the user)
    assert numba.config.CACHE_DIR.startswith(os.environ["NUMBA_CACHE_DIR"] + os.sep)


def test_a_test_run_ends_with_its_skips_grouped_by_reason(tmp_path):
    (tmp_path / "conftest.py").write_text(
        f"import sys\nsys.path.insert(0, {str(ROOT / 'tests')!r})\n"
        "from skip_summary import pytest_terminal_summary  # noqa: F401\n"
    )
    (tmp_path / "test_a.py").write_text(
        textwrap.dedent("""
        import pytest

        @pytest.mark.parametrize("i", range(3))
        def test_browser(i):
            pytest.skip("no Chromium (viewer browser tests)")

        def test_urdf():
            pytest.skip("ARMAR-6 URDF not found")

        def test_ok():
            pass
    """)
    )
    (tmp_path / "test_b.py").write_text(
        "import pytest\n\n@pytest.mark.skip(reason='ARMAR-6 URDF not found')\ndef test_other():\n    pass\n"
    )
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-ra", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=dict(os.environ, PYTEST_DISABLE_PLUGIN_AUTOLOAD="1"),
    )
    lines = proc.stdout.splitlines()
    assert proc.returncode == 0, proc.stdout
    start = next(i for i, line in enumerate(lines) if "5 skipped, by reason" in line)
    assert lines[start + 1 : start + 3] == [
        "3 skipped: no Chromium (viewer browser tests) (test_a.py)",
        "2 skipped: ARMAR-6 URDF not found (test_a.py, test_b.py)",
    ]
    # after pytest's own one-per-test list, and pytest's count stays the closing line
    assert start > max(i for i, line in enumerate(lines) if line.startswith("SKIPPED"))
    assert re.fullmatch(r"1 passed, 5 skipped in .*", lines[-1])
