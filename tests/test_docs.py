"""The documentation site: it builds with warnings as errors, its benchmark tables come from files
that commands write (never typed into a page), and the user docs carry no dates or issue numbers."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").glob("*.md"))
#: pages that report measurements: every table on them is an included file
BENCHMARK_PAGES = ("benchmarks.md", "dask.md", "evaluation.md", "robots.md")
INCLUDE = re.compile(r'^--8<-- "([^"]+)"\s*$', re.MULTILINE)


def included_tables() -> list[tuple[str, str]]:
    """(page, included path) of every snippet include in the pages."""
    return [(page.name, path) for page in PAGES for path in INCLUDE.findall(page.read_text())]


def writers_of(path: str) -> list[str]:
    """The sources that write ``path``: a tool naming it, or (for ``placement evaluate --out DIR``'s
    summary) the Makefile rule naming DIR and the command naming the file."""
    tools = [p for p in sorted((ROOT / "tools").glob("*.py")) if path in p.read_text()]
    if tools:
        return [p.name for p in tools]
    folder, name = path.rsplit("/", 1)
    make = (ROOT / "Makefile").read_text()
    command = ROOT / "placement/cli/evaluate.py"
    if f"--out {folder}\n" in make and f'"{name}"' in command.read_text():
        return ["Makefile", "placement/cli/evaluate.py"]
    return []


#: a Sphinx cross-reference role as it would be left in a page: ":func:" before a code span (rendered or not)
ROLE_TEXT = re.compile(r":(?:py:)?(?:func|class|mod|data|attr|meth|exc|obj|const):(?:`|<code>)")


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site, built once for the tests of this module (--strict; the build's stderr is checked by
    :func:`test_the_site_builds_with_warnings_as_errors`)."""
    if importlib.util.find_spec("mkdocs") is None:
        pytest.skip("mkdocs is not installed (the docs extra)")
    out_dir = tmp_path_factory.mktemp("site")
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out_dir)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
    )
    assert out.returncode == 0, out.stderr[-3000:]
    assert "WARNING" not in out.stderr, out.stderr[-3000:]
    return out_dir


@pytest.mark.slow
def test_the_site_builds_with_warnings_as_errors(site):
    assert (site / "api/planning/index.html").is_file()


def test_api_pages_render_sphinx_roles_as_code_and_links(site):
    """docs/griffe_roles.py: no ":func:`x`" is left in the API reference, and roles naming a documented
    object link to its anchor."""
    pages = sorted((site / "api").glob("*/index.html"))
    assert len(pages) == len(list((ROOT / "docs/api").glob("*.md")))
    left = {p.parent.name: ROLE_TEXT.findall(p.read_text()) for p in pages}
    assert not any(left.values()), f"role text left in the API pages: { {k: v for k, v in left.items() if v} }"
    planning = (site / "api/planning/index.html").read_text()
    # Planner's docstring: "change them through :meth:`set_method` and :meth:`update`"
    assert 'href="#placement.planning.Planner.set_method"><code>set_method</code></a>' in planning
    # "~" shows the last component only, linked to the documented object on another page
    assert 'href="../collision/#placement.collision.SceneCollision"><code>SceneCollision</code></a>' in planning
    # a role naming an object no page documents is plain code, not a broken link
    assert "<code>PlanningContext</code>" in planning and "[PlanningContext]" not in planning


def test_every_included_table_exists_and_a_command_writes_it():
    includes = included_tables()
    assert {page for page, _ in includes} >= set(BENCHMARK_PAGES)
    for page, path in includes:
        assert (ROOT / path).is_file(), f"{page} includes {path}, which does not exist"
        assert writers_of(path), f"{page} includes {path}, but no tool, Makefile rule or command names it"


@pytest.mark.parametrize("page", BENCHMARK_PAGES)
def test_benchmark_pages_type_no_tables(page):
    typed = [line for line in (ROOT / "docs" / page).read_text().splitlines() if line.lstrip().startswith("|")]
    assert typed == [], f"docs/{page} types a table; include the file its command writes instead"


@pytest.mark.parametrize("path", [ROOT / "README.md", *PAGES], ids=lambda p: p.name)
def test_no_dates_or_issue_numbers_in_the_user_docs(path):
    text = path.read_text()
    assert not re.findall(r"20\d\d-\d\d-\d\d", text), f"{path.name} holds a date"
    assert not re.findall(r"issue #|\bissues? \d", text, re.IGNORECASE), f"{path.name} names an issue number"
    assert not re.findall(r"(?<![\w&])#\d+\b", text), f"{path.name} names an issue number"
