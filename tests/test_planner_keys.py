"""The scene's table of planner settings (placement/scene/planner_keys.py) and the planner's configuration
built from it."""

from __future__ import annotations

import re
from dataclasses import fields

from placement.planning import settings
from placement.planning.settings import PlannerConfig
from placement.scene import planner_keys


def test_the_settable_fields_are_the_table():
    settable = {f.name: f for f in fields(PlannerConfig) if f.metadata}
    assert set(settable) == set(planner_keys.PLANNER_SETTINGS)
    for name, setting in planner_keys.PLANNER_SETTINGS.items():
        assert settable[name].default == setting["default"], name
        assert dict(settable[name].metadata) == planner_keys.PLANNER_BOUNDS[name], name


def test_each_help_text_names_its_default():
    for name, setting in planner_keys.PLANNER_SETTINGS.items():
        stated = re.search(r"\(default ([^;)]+)", setting["help"])
        assert stated, f"{name}: its help text states no default"
        assert eval(stated.group(1)) == setting["default"], name  # the texts say "1/20", "0.02", ...


def test_every_default_is_within_its_bounds():
    for name, setting in planner_keys.PLANNER_SETTINGS.items():
        low, high, value = setting["minimum"], setting["maximum"], setting["default"]
        assert (low < value if setting.get("strict") else low <= value) and value <= high, name


def test_the_planner_config_re_exports_the_table():
    assert settings.PLANNER_KEYS is planner_keys.PLANNER_KEYS
    assert settings.PLANNER_BOUNDS is planner_keys.PLANNER_BOUNDS
    assert settings.MAX_WEIGHT == planner_keys.MAX_WEIGHT
    assert PlannerConfig.from_overrides({"lambda_n": 0.5}).lambda_n == 0.5
