"""Plan documents compared across runs."""

from __future__ import annotations


def strip_timings(value):
    """The plan without its timings (they change from run to run)."""
    if isinstance(value, dict):
        return {k: strip_timings(v) for k, v in value.items() if k not in ("timings_ms", "update")}
    if isinstance(value, list):
        return [strip_timings(v) for v in value]
    return value
