"""The map threshold of each arm and torso setting: resolved once at load, applied per option.

A map value means different things on different arms, so the threshold is by default a quantile of
each arm's own non-zero map values (``planner.threshold_quantile``, see
:mod:`placement.maps.quantiles`); a scene's ``planner.threshold`` is a map value used on every arm and
setting. The planner resolves either into one value per arm (:func:`resolve_thresholds`, from the arm's
own map: the reference torso setting's) and, for a map built once per torso setting (a revolute torso,
``kind: per_setting`` in :mod:`placement.maps.torso`), one per (arm, setting) from that setting's own
distribution (:func:`setting_thresholds`); a shifted map (a prismatic lift: the same array moved) has
one distribution, so all its settings keep the arm's threshold. Both are one :class:`Thresholds`
value, held once by a planner and shared by its planning context and per-step cache
(:meth:`Thresholds.at` picks an option's); ``PlannerConfig.threshold`` then holds the smallest of them
all, for the code that needs one number (messages) and for :func:`per_arm_values`, which lets a
single-threshold ranking apply every option's own.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from placement.maps.rmap import ReachabilityMap
from placement.planning.problems.option import Option
from placement.planning.problems.torso_maps import map_variants, torso_record, torso_value
from placement.planning.settings import PlannerConfig

#: (arm, torso value [rad]) -> its map threshold (map value, dimensionless)
SettingThresholds = Mapping[tuple[str, float], float]


def resolve_thresholds(config: PlannerConfig, maps: Mapping[str, ReachabilityMap]) -> dict[str, float]:
    """arm -> its threshold (map value, dimensionless): ``config.threshold`` on every arm when the scene
    gave it (``threshold_quantile`` None), else each map's value at ``threshold_quantile`` (the arm's own
    map: the reference setting's for a map with torso settings)."""
    q = config.threshold_quantile
    if q is None:
        return {arm: float(config.threshold) for arm in maps}
    # > 0 (a quantile of positive values): cells an arm does not reach (value 0) stay infeasible
    return {arm: rmap.quantile_value(q) for arm, rmap in maps.items()}


def setting_thresholds(config: PlannerConfig, maps: Mapping[str, ReachabilityMap]) -> dict[tuple[str, float], float]:
    """(arm, torso value [rad]) -> the threshold (map value) of every setting of each map built once per
    setting (any kind but shifted): that setting's own map's value at ``threshold_quantile``. Empty when
    the scene gave ``threshold`` (one value everywhere); a map without torso settings or a shifted one
    has no entries (its settings share one distribution: the arm's threshold)."""
    q = config.threshold_quantile
    if q is None:
        return {}
    out: dict[tuple[str, float], float] = {}
    for arm, views in map_variants(maps).items():
        record = torso_record(maps[arm])
        if record is None or record.kind == "shifted":
            continue
        for view in views:
            value = torso_value(view)
            assert value is not None  # a view of a record stands for a setting
            out[(arm, value)] = view.quantile_value(q)
    return out


def threshold_at(
    thresholds: Mapping[str, float], settings: SettingThresholds, default: float, arm: str, torso: float | None
) -> float:
    """The threshold (map value) of ``arm`` at torso value ``torso`` [m or rad]: the setting's own
    (``settings``), else the arm's (``thresholds``), else ``default``."""
    if torso is not None:
        own = settings.get((arm, torso))
        if own is not None:
            return own
    return thresholds.get(arm, default)


@dataclass(frozen=True)
class Thresholds:
    """The map thresholds a plan applies (map values, dimensionless).

    Attributes:
        arms: arm -> its threshold (:func:`resolve_thresholds`).
        settings: (arm, torso value [rad]) -> the threshold of that setting of a map built once per
            setting (:func:`setting_thresholds`; else its arm's).
        default: the threshold of an arm in neither (``PlannerConfig.threshold``).
    """

    arms: Mapping[str, float] = field(default_factory=dict)
    settings: SettingThresholds = field(default_factory=dict)
    default: float = 0.0

    @classmethod
    def resolve(cls, config: PlannerConfig, maps: Mapping[str, ReachabilityMap]) -> tuple[Thresholds, PlannerConfig]:
        """The thresholds of ``maps`` under ``config``, and ``config`` with ``threshold`` the smallest of
        them (:func:`with_threshold`), which is also their ``default``."""
        arms = resolve_thresholds(config, maps)
        settings = setting_thresholds(config, maps)
        config = with_threshold(config, arms, settings)
        return cls(arms, settings, float(config.threshold)), config

    def at(self, arm: str, torso: float | None = None) -> float:
        """The threshold of ``arm`` at torso value ``torso`` [m or rad] (None: its own map's)."""
        return threshold_at(self.arms, self.settings, self.default, arm, torso)

    def of(self, option: Option) -> float:
        """The threshold of ``option``: its arm's at its torso setting."""
        return self.at(option.arm, option.torso)

    def scaled(self, factor: float) -> Thresholds:
        """Every threshold multiplied by ``factor``."""
        return Thresholds(
            {a: t * factor for a, t in self.arms.items()},
            {k: t * factor for k, t in self.settings.items()},
            self.default * factor,
        )

    def relaxed(self, factor: float) -> Thresholds:
        """The thresholds a step is planned with when relaxed by ``factor`` (see
        ``StepProblems.relaxed``): these themselves at 1 or more, else :meth:`scaled` by it."""
        return self if factor >= 1.0 else self.scaled(factor)

    def words(self, arm: str) -> str:
        """``arm``'s threshold in words: one value, or one per torso setting of a map built once per
        setting ("0.0123 at torso 0, 0.0151 at torso 0.4")."""
        own = sorted((t, v) for (a, t), v in self.settings.items() if a == arm)
        if not own:
            return f"{self.at(arm):.4g}"
        return ", ".join(f"{v:.4g} at torso {t:g}" for t, v in own)


def with_threshold(
    config: PlannerConfig, thresholds: Mapping[str, float], settings: SettingThresholds | None = None
) -> PlannerConfig:
    """``config`` with ``threshold`` the smallest of ``thresholds`` and ``settings`` (unchanged when there
    are none)."""
    every = [*thresholds.values(), *(settings or {}).values()]
    return replace(config, threshold=min(every)) if every else config


def per_arm_values(
    options: Sequence[Option], threshold: Callable[[str, float | None], float], floor: float
) -> list[Option]:
    """``options`` with each value below its own threshold (``threshold(arm, torso)``, the option's arm
    and torso setting) set to 0, for code that applies one threshold ``floor`` (the smallest, > 0) to
    every option (the Eq. 6 ranking): it then keeps exactly the cells each option's own threshold keeps.
    The options themselves when no option's threshold lies above ``floor``."""
    out = list(options)
    for k, o in enumerate(out):
        t = threshold(o.arm, o.torso)
        if t > floor:
            out[k] = replace(o, value=np.where(o.value >= np.float32(t), o.value, np.float32(0)))
    return out


__all__ = [
    "SettingThresholds",
    "Thresholds",
    "per_arm_values",
    "resolve_thresholds",
    "setting_thresholds",
    "threshold_at",
    "with_threshold",
]
