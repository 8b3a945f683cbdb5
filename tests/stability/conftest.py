"""Stability tests: MuJoCo kept quiet (they provoke warnings on purpose), and the hard-case builders.

A hard case is a short top-drape trial (or a probe in air) run through the runner at the measured envelope's
timestep, under the trial watchdog bounds; the builders return what it did for the tests to assert on.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
import pytest

from entangle_bench import stability
from entangle_bench.calibration import candidate_overrides
from entangle_bench.runner import TrialResult, simulate
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config
from entangle_bench.suite.probe import ProbeConfig
from entangle_bench.watchdog import WatchdogLimits

#: Pseudo-preset of the hard cases: the grasp calibration candidate (`calibration.candidate_overrides`: 40
#: hinge segments, Euler 0.25 ms, stiff elliptic contact) with the short sequence's phases.
CANDIDATE = "candidate"

#: Watchdog bounds asserted by every hard case (the trial defaults): 20 m/s, 5 mm after 0.2 s, energy.
LIMITS = WatchdogLimits()


@pytest.fixture(autouse=True)
def _quiet(quiet_mujoco):
    """Every stability test runs with MuJoCo's warning printer silenced."""
    yield


@dataclass
class CaseRun:
    """What a hard case did (SI units)."""

    result: TrialResult
    config: Any
    """The configuration run (its timestep lowered to the envelope's if needed)."""
    preset_timestep_s: float
    """The preset's own timestep."""
    preset_warnings: list[str]
    """Envelope warnings of the configuration at the preset's own timestep."""
    warnings: dict[str, int] = field(default_factory=dict)
    """MuJoCo warning counters that fired (any kind)."""
    finite: bool = True

    def describe(self) -> str:
        """One line for assertion messages."""
        r = self.result
        return (
            f"reason={r.reason!r} t={r.time_s:.3f}s dt={self.config.numerics.timestep_s:g}s "
            f"stats={r.stats} warnings={self.warnings}"
        )


def within_envelope(config: Any) -> Any:
    """`config` with its timestep lowered to the measured envelope's when it lies above it; a skip (after checking
    the envelope warns) where no measured timestep is stable."""
    limit = stability.stable_timestep_s(config)
    if limit is None or config.numerics.timestep_s <= limit:
        return config
    if limit == 0:
        warnings = stability.envelope_warnings(config)
        assert any("none down to" in w for w in warnings), warnings
        pytest.skip(f"no timestep of the measured map is stable here, and the envelope says so: {warnings[0]}")
    return dataclasses.replace(config, numerics=dataclasses.replace(config.numerics, timestep_s=limit))


def _fired(data: mujoco.MjData) -> dict[str, int]:
    return {mujoco.mjtWarning(k).name: int(w.number) for k, w in enumerate(data.warning) if w.number > 0}


@pytest.fixture
def limits() -> WatchdogLimits:
    """The watchdog bounds every hard case asserts."""
    return LIMITS


@pytest.fixture
def resolve_case() -> Callable[..., Any]:
    """Builder: the short top-drape trial of `task` with a preset (or CANDIDATE: the calibration candidate's
    gripper, contact and numerics) and the case's overrides."""

    def build(preset: str, overrides: list[str], task: str = "top_drape/eight_branch_tree") -> Any:
        if preset == CANDIDATE:
            return resolve_config(task, None, candidate_overrides() + SHORT_SEQUENCE + overrides)
        return resolve_config(task, preset, SHORT_SEQUENCE + overrides)

    return build


@pytest.fixture
def run_trial_case(start_hook) -> Callable[..., CaseRun]:
    """Runner of a top-drape hard case at the envelope's timestep: (config, seed, prepare(physics)) -> CaseRun."""

    def run(config: Any, seed: int = 0, prepare: Callable[[Any], None] | None = None) -> CaseRun:
        used = within_envelope(config)
        observers = [] if prepare is None else [start_hook(prepare)]
        task = f"top_drape/{used.object_name}"
        result = simulate(task, used, seed, limits=LIMITS, observers=observers)
        data = result.env.physics.data.ptr
        return CaseRun(
            result=result,
            config=used,
            preset_timestep_s=config.numerics.timestep_s,
            preset_warnings=stability.envelope_warnings(config),
            warnings=_fired(data),
            finite=bool(np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))),
        )

    return run


@pytest.fixture
def run_probe_case() -> Callable[..., TrialResult]:
    """Runner of a probe (gripper alone, in air) at the envelope's timestep, under the trial's bounds."""

    def run(config: ProbeConfig, seed: int = 0) -> TrialResult:
        return simulate("probe/curl_in_air", within_envelope(config), seed, limits=LIMITS)

    return run
