"""Running a hard case: a short top-drape trial (or a probe) under the watchdog, worst values."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import mujoco
import numpy as np

from entangle_bench import stability
from entangle_bench.suite import resolve_config
from entangle_bench.suite.top_drape import TopDrapeConfig, make_environment, scripted_action
from entangle_bench.watchdog import Watchdog, WatchdogLimits, WatchdogStats, WatchdogTripped
from tests.suite.test_top_drape import SHORT

#: Watchdog bounds asserted by every hard case (the trial defaults): 20 m/s, 5 mm after 0.2 s,
#: energy.
LIMITS = WatchdogLimits()


@dataclass
class CaseRun:
    """What a hard case did (SI units)."""

    config: TopDrapeConfig
    preset_timestep_s: float
    """The preset's own timestep; the run used config.numerics.timestep_s (smaller if needed)."""
    preset_warnings: list[str]
    """Envelope warnings of the configuration at the preset's own timestep."""
    reason: str
    time_s: float
    stats: WatchdogStats
    warnings: dict[str, int] = field(default_factory=dict)
    """MuJoCo warning counters that fired (any kind)."""
    finite: bool = True
    wall_time_s: float = 0.0

    def describe(self) -> str:
        """One line for assertion messages."""
        return (
            f"reason={self.reason!r} t={self.time_s:.3f}s dt={self.config.numerics.timestep_s:g}s "
            f"stats={self.stats} warnings={self.warnings} wall={self.wall_time_s:.1f}s"
        )


def within_envelope(config: TopDrapeConfig) -> TopDrapeConfig:
    """`config` with its timestep lowered to the measured envelope's when it lies above it."""
    limit = stability.stable_timestep_s(config)
    if limit is None or config.numerics.timestep_s <= limit:
        return config
    return dataclasses.replace(
        config, numerics=dataclasses.replace(config.numerics, timestep_s=limit)
    )


def resolve_case(
    preset: str, overrides: list[str], task: str = "eight_branch_tree"
) -> TopDrapeConfig:
    """The short top-drape trial of `task` with a preset and the case's overrides."""
    return resolve_config(task, preset, SHORT + overrides)


def run_trial_case(
    config: TopDrapeConfig,
    seed: int = 0,
    prepare: Callable[[object], None] | None = None,
) -> CaseRun:
    """Scripted trial at the envelope's timestep, watchdog on; `prepare(physics)` after reset."""
    used = within_envelope(config)
    env = make_environment(used, seed)
    step = env.reset()
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    if prepare is not None:
        prepare(physics)
        mujoco.mj_forward(model, data)
    watchdog = Watchdog(model, data, LIMITS, stability.actuation_energy_j(used.scene_config()))
    reason, start = "", time.perf_counter()
    try:
        while not step.last():
            step = env.step(scripted_action(used, env.task.schedule, physics.time()))
            watchdog.check(model, data)
    except WatchdogTripped as exc:
        reason = exc.reason
    return CaseRun(
        config=used,
        preset_timestep_s=config.numerics.timestep_s,
        preset_warnings=stability.envelope_warnings(config),
        reason=reason,
        time_s=physics.time(),
        stats=watchdog.stats,
        warnings=_fired(data),
        finite=bool(np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))),
        wall_time_s=time.perf_counter() - start,
    )


def run_probe_case(config, duration_s: float = 1.0, seed: int = 0) -> stability.ProbeResult:
    """A probe (gripper alone, in air) at the envelope's timestep, under the trial's bounds."""
    used = within_envelope(config)
    return stability.probe(used, duration_s=duration_s, seed=seed, limits=LIMITS)


def _fired(data: mujoco.MjData) -> dict[str, int]:
    return {
        mujoco.mjtWarning(k).name: int(w.number) for k, w in enumerate(data.warning) if w.number > 0
    }
