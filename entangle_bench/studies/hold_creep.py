"""Does a held grasp creep? One trial to a phase, then the rest from that same state once per solver variant.

MuJoCo's soft contacts have no static friction: under a steady tangential load a contact slides slowly, so
an object held by friction sinks at a rate set by the solver's regularization (`impratio`, the time
constant) unless the noslip post-solver removes it. Both functions run one top-drape trial to the start of
a phase, save it (`branching.SavedTrial`) and continue from it once per variant with the scripted policy, so
every variant starts from the identical grasp and the variants compare solvers, not seeds. A variant changes
fields of `mjOption` (e.g. `noslip_iterations`) or the config fields the task reads at every step
(`RUN_TIME_PATHS`, e.g. `numerics.impratio_phases`: impratio 10 from the hold instead of the lift):

- `hold_branches`: the hold, `hold_s` seconds (hub still, pressure on): sink rates;
- `branch_outcomes`: the rest of the trial from `start_phase` (e.g. the lift) with the scripted policy,
  under the watchdog: the task's own outcome and metrics per variant.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np
import pandas as pd
from dm_control.rl.control import PhysicsError

from entangle_bench.config import apply_overrides
from entangle_bench.errors import ParameterError
from entangle_bench.presets import PER_PHASE_OPTIONS
from entangle_bench.results import UNSTABLE
from entangle_bench.studies.branching import SavedTrial, option_variants, run_until
from entangle_bench.suite import TASKS
from entangle_bench.suite.top_drape import object_tilt_deg
from entangle_bench.watchdog import Watchdog, WatchdogTripped

#: Config fields a continuation may change: the task reads them at every step (`Numerics.phase_options`); every
#: other field is built into the model and would not change by replacing the config mid-trial.
RUN_TIME_PATHS = tuple(
    f"numerics.{name}" for option, (field_name, _) in PER_PHASE_OPTIONS.items() for name in (option, field_name)
)

_OPTION_FIELDS = tuple(name for name in dir(mujoco.MjOption) if not name.startswith("_"))


def _variant_configs(
    task: str, config: Any, seed: int, variants: Mapping[str, Mapping[str, Any]]
) -> dict[str, tuple[dict[str, Any], Any]]:
    """Per variant, its mjOption changes and its config (`config` with its RUN_TIME_PATHS changes, text as `--set`
    takes it), checked before anything simulates: unknown or build-time config paths, values out of range,
    phase names the task lacks, and mjOption fields the variant's config switches per phase are refused."""
    prepared = {}
    for name, changes in variants.items():
        options = {key: value for key, value in changes.items() if "." not in key}
        unknown = sorted(set(options) - set(_OPTION_FIELDS))
        if unknown:
            raise ParameterError(f"variant {name!r}: {', '.join(unknown)} not an mjOption field; known: "
                                 f"{', '.join(_OPTION_FIELDS)}")
        paths = {key: value for key, value in changes.items() if "." in key}
        for path in paths:
            if path not in RUN_TIME_PATHS:
                raise ParameterError(
                    f"variant {name!r} sets {path}, which the model is built from; a continuation may change "
                    f"mjOption fields or {', '.join(RUN_TIME_PATHS)}"
                )
        # Together, as `--set` applies them: noslip_phases is only valid with noslip_iterations > 0.
        variant_config = apply_overrides(config, [f"{path}={value}" for path, value in paths.items()])
        if paths:
            TASKS.get(task).make_environment(variant_config, seed)  # the task checks its phase names
        for option, (field_name, _) in PER_PHASE_OPTIONS.items():
            phases = getattr(variant_config.numerics, field_name)
            if phases and option in options:
                raise ParameterError(
                    f"variant {name!r} sets {option}, but numerics.{field_name}={list(phases)} makes the task "
                    f"set it at every step; set numerics.{option} and numerics.{field_name} in the variant instead"
                )
        prepared[name] = (options, variant_config)
    return prepared


def _continue_as(env: Any, saved: SavedTrial, variant_config: Any) -> None:
    """Restore the saved state and give the task the variant's config (only its RUN_TIME_PATHS differ)."""
    saved.restore(env)
    env.task.config = variant_config


def _branch_point(task: str, config: Any, seed: int, phase: str) -> tuple[Any, SavedTrial]:
    """The trial's environment at the first control step of `phase`, and its saved state."""
    env, ended = run_until(task, config, seed, lambda env: env.task.phase(env.physics) == phase)
    if ended:
        raise ParameterError(f"{task}: the trial ended before its phase {phase!r} began")
    return env, SavedTrial.take(env)


def hold_branches(
    task: str, config: Any, seed: int, variants: Mapping[str, Mapping[str, Any]], hold_s: float
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Hold the grasp of one trial `hold_s` s once per variant (name -> mjOption fields and RUN_TIME_PATHS) from
    the same state.

    Returns a summary (one row per variant: the object's lowest point at the start and end of the hold, m;
    its sink rate over the second half, m/s, from a least-squares line; the end tilt, deg; when it first fell
    below the task's success margin, s after the hold began, NaN if never; the deepest contact, m; wall s)
    and the series (variant, hold time s, lowest point m, tilt deg) sampled every control step.
    """
    if hold_s <= 0:
        raise ParameterError(f"hold_s = {hold_s} must be positive")
    config = dataclasses.replace(config, phases=dataclasses.replace(config.phases, hold_time_s=hold_s))
    prepared = _variant_configs(task, config, seed, variants)
    env, saved = _branch_point(task, config, seed, "hold")
    physics = env.physics
    data = physics.data.ptr
    rows, series = [], []
    for name in option_variants(physics.model.ptr, {name: options for name, (options, _) in prepared.items()}):
        _continue_as(env, saved, prepared[name][1])
        start, clock, deepest, below, trace = data.time, time.perf_counter(), 0.0, math.nan, []
        while True:
            low, t = physics.object_lowest_z(), data.time - start
            trace.append((t, low, object_tilt_deg(physics.object_pose()[1])))
            if data.ncon:
                deepest = max(deepest, -float(data.contact.dist[: data.ncon].min()))
            if math.isnan(below) and low < config.success_margin_m:
                below = t
            if t >= hold_s - 1e-9:
                break
            env.step(env.task.scripted_action(physics))
        series += [(name, *point) for point in trace]
        trace = pd.DataFrame(trace, columns=["t_s", "low_m", "tilt_deg"])
        late = trace[trace["t_s"] >= hold_s / 2]
        rows.append({
            "variant": name,
            "start_low_m": trace["low_m"].iloc[0],
            "end_low_m": trace["low_m"].iloc[-1],
            "sink_rate_m_s": -float(np.polyfit(late["t_s"], late["low_m"], 1)[0]) if len(late) > 1 else math.nan,
            "end_tilt_deg": trace["tilt_deg"].iloc[-1],
            "below_margin_at_s": below,
            "deepest_contact_m": deepest,
            "wall_s": time.perf_counter() - clock,
        })
    return pd.DataFrame(rows), pd.DataFrame(series, columns=["variant", "t_s", "low_m", "tilt_deg"])


def branch_outcomes(
    task: str, config: Any, seed: int, variants: Mapping[str, Mapping[str, Any]], start_phase: str = "lift"
) -> pd.DataFrame:
    """The rest of one trial from the start of `start_phase`, once per variant (name -> mjOption fields and
    RUN_TIME_PATHS).

    Each continuation runs the scripted policy through the environment under a watchdog started at the
    branch point with the task's limits; one row per variant: outcome, failure mode (or unstable reason), the
    task's metrics (lift, tilt, support by source...), the deepest contact (m), the simulated time it ended at
    (s) and wall s. Every continuation runs to the episode's end in simulated time, whatever its timestep.
    """
    prepared = _variant_configs(task, config, seed, variants)
    env, saved = _branch_point(task, config, seed, start_phase)
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    end_s = env.task.schedule.boundaries()[-1][1]
    rows = []
    for name in option_variants(model, {name: options for name, (options, _) in prepared.items()}):
        _continue_as(env, saved, prepared[name][1])
        clock = time.perf_counter()
        watchdog = Watchdog(model, data, env.task.watchdog_limits(), env.task.actuation_energy_j())
        row: dict[str, Any] = {"variant": name, "unstable_reason": ""}
        try:
            while data.time < end_s - 1e-9:
                # dm_control counts the episode in control steps of the configured timestep; a variant with a
                # shorter one needs more of them, so the episode ends by simulated time, never by a reset.
                env._reset_next_step = False
                env.step(env.task.scripted_action(physics))
                watchdog.check(model, data)
        except (WatchdogTripped, PhysicsError, mujoco.FatalError) as exc:
            row.update(outcome=UNSTABLE, failure_mode="", unstable_reason=str(exc))
        else:
            outcome = env.task.outcome
            row.update(outcome=outcome.status, failure_mode=outcome.failure_mode)
        row.update(env.task.metrics(physics))
        row["max_penetration_m"] = watchdog.stats.max_penetration_m
        row["end_time_s"] = float(data.time)
        row["wall_s"] = time.perf_counter() - clock
        rows.append(row)
    return pd.DataFrame(rows)
