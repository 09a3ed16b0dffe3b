"""The closing "what was skipped and why" of a test run (hook used by tests/conftest.py).

pytest's ``-ra`` lists every skipped test on its own line; a run that skips 44 tests for one reason
buries the reason. :func:`pytest_terminal_summary` adds one line per reason after that list, e.g.::

    =================== 47 skipped, by reason ===================
    44 skipped: ARMAR-6 URDF not found ... (test_build.py, test_ik.py, ...)
    3 skipped: no chromium on PATH ... (test_viewer_browser.py)
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import pytest

MAX_FILES = 4  # test files named per reason


def skip_reason(report) -> str:
    """The reason a skipped report gives, without pytest's "Skipped: " prefix."""
    longrepr = report.longrepr
    if isinstance(longrepr, tuple) and len(longrepr) == 3:
        reason = str(longrepr[2])
    else:
        reason = str(longrepr)
    reason = reason.removeprefix("Skipped: ").strip()
    return " ".join(reason.split()) or "(no reason given)"


def skip_groups(reports) -> list[tuple[str, int, list[str]]]:
    """(reason, count, test files) per distinct reason, the most frequent first."""
    files: dict[str, list[str]] = defaultdict(list)
    counts: dict[str, int] = defaultdict(int)
    for report in reports:
        reason = skip_reason(report)
        counts[reason] += 1
        name = Path(report.nodeid.split("::", 1)[0]).name
        if name not in files[reason]:
            files[reason].append(name)
    return sorted(((r, counts[r], sorted(files[r])) for r in counts), key=lambda g: (-g[1], g[0]))


def summary_lines(reports) -> list[str]:
    lines = []
    for reason, count, names in skip_groups(reports):
        shown = ", ".join(names[:MAX_FILES]) + (f", +{len(names) - MAX_FILES} more" if len(names) > MAX_FILES else "")
        lines.append(f"{count} skipped: {reason} ({shown})")
    return lines


@pytest.hookimpl(wrapper=True, tryfirst=True)
def pytest_terminal_summary(terminalreporter, exitstatus, config):
    # outermost wrapper: runs after pytest's own summary (the -ra list), just before the closing line
    try:
        return (yield)
    finally:
        skipped = [r for r in terminalreporter.stats.get("skipped", []) if getattr(r, "longrepr", None)]
        if skipped:
            terminalreporter.write_sep("=", f"{len(skipped)} skipped, by reason")
            for line in summary_lines(skipped):
                terminalreporter.write_line(line)
