"""Tasks by name, loaded like `dm_control.suite.load`; configurations resolved in one place.

    env = load("top_drape", "eight_branch_tree", offset=0.01, seed=3)

`TASKS` (`suite.base.TaskRegistry`) holds every task as 'domain/name' with its config type, default config and
environment factory; families register with `suite.base.register_task`. Domains: `top_drape` (one task per
object of the object library, `suite.top_drape`), `pullout` (the pull-out test, one task per object,
`suite.pullout`) and `probe` (the stability probe, `suite.probe`). A bare name means `top_drape/<name>`, and
`<domain>_<name>` means `<domain>/<name>` (`pullout_sphere`). `resolve_config` is the one place a task's
configuration is resolved: default config, numerical preset, `a.b=value` overrides, centering offset.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from dm_control.rl import control

from entangle_bench.config import apply_overrides, replace_path
from entangle_bench.errors import ParameterError
from entangle_bench.presets import apply_preset
from entangle_bench.suite import probe, pullout, top_drape  # noqa: F401  (the task families register their tasks)
from entangle_bench.suite.base import TASKS, BenchTask, Outcome, TaskDef, register_task

__all__ = [
    "SHORT_PULL_SEQUENCE",
    "SHORT_SEQUENCE",
    "TASKS",
    "BenchTask",
    "Outcome",
    "TaskDef",
    "load",
    "register_task",
    "resolve_config",
]

#: Overrides for a short top-drape sequence (about 2.7 s simulated instead of 7.6 s): smoke tests, CI and
#: quick benchmarks. Use with `resolve_config(task, preset, SHORT_SEQUENCE + [...])`.
SHORT_SEQUENCE = [
    "phases.drape_depth_m=0.03",
    "phases.ramp_time_s=0.2",
    "phases.settle_time_s=0.1",
    "phases.lift_height_m=0.03",
    "phases.lift_speed_m_s=0.1",
    "phases.hold_time_s=0.3",
    "phases.release_time_s=0.1",
]

#: Overrides for a short pull-out sequence (about 1 s simulated): the drape of SHORT_SEQUENCE, then a 30 mm pull
#: at 0.1 m/s. Use with `resolve_config("pullout/<object>", preset, SHORT_PULL_SEQUENCE + [...])`.
SHORT_PULL_SEQUENCE = [
    *SHORT_SEQUENCE[:3],
    "pull.clamp_time_s=0.05",
    "pull.accel_time_s=0.02",
    "pull.speed_m_s=0.1",
    "pull.max_travel_m=0.03",
]


def resolve_config(
    task: str,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    offset: float | None = None,
) -> Any:
    """Default config of `task` with a numerical preset, `a.b=value` overrides and an offset (m) applied."""
    config = apply_preset(TASKS.get(task).default_config(), preset)
    try:
        config = apply_overrides(config, overrides)
        if offset is not None:
            config = replace_path(config, "offset_m", float(offset))
    except TypeError as exc:
        raise ParameterError(f"invalid override for task {task}: {exc}") from None
    return config


def load(
    domain: str,
    task: str,
    *,
    seed: int = 0,
    offset: float | None = None,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    config: Any = None,
) -> control.Environment:
    """Load a registered task as a dm-control environment (offset in m; seed drives all randomness)."""
    entry = TASKS.get(f"{domain}/{task}")
    if config is None:
        config = resolve_config(entry.name, preset, overrides, offset)
    return entry.make_environment(config, seed)
