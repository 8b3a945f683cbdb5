"""The trial runner: owns the step loop and the watchdog, runs trials in worker processes, writes results.

A trial is (task, resolved configuration, seed). `run_trial` drives the dm-control environment with the
scripted top-drape policy, checks the watchdog after every control step, records entanglement metrics at
the end of actuation and at the end of the hold, and returns one results row. `run_trials` runs many trials
through an `Executor` (local worker processes by default), appends each finished row to the trial log at
once, skips trials already in the log, and shows progress.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import hashlib
import importlib.metadata
import json
import multiprocessing
import platform
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import mujoco
import numpy as np
from dm_control.rl.control import PhysicsError
from tqdm import tqdm

import entangle_bench
from entangle_bench.atomic import atomic_save_npz
from entangle_bench.config import to_flat_dict
from entangle_bench.metrics.acn import acn_total
from entangle_bench.metrics.contacts import contact_summary
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.recording import TrialRecorder
from entangle_bench.results import TrialLog
from entangle_bench.suite.top_drape import TopDrapeConfig, make_environment, scripted_action
from entangle_bench.viz import object_geometry, pack
from entangle_bench.watchdog import Watchdog, WatchdogLimits, WatchdogTripped

LOCAL_ACN_DIAMETER_M = 0.02


@dataclass(frozen=True)
class TrialSpec:
    """One trial to run."""

    task: str
    condition: str
    config: TopDrapeConfig
    seed: int
    preset: str
    params: tuple[tuple[str, Any], ...] = ()
    """The condition's swept parameters (name, value), copied into the row for grouping."""

    @property
    def trial_id(self) -> str:
        """Stable id of (task, resolved configuration, seed)."""
        payload = json.dumps(
            [self.task, to_flat_dict(self.config), self.seed], sort_keys=True, default=repr
        )
        return hashlib.sha1(payload.encode()).hexdigest()[:16]


def versions() -> dict[str, str]:
    """Software versions recorded with every row."""
    return {
        "version.entangle_bench": entangle_bench.__version__,
        "version.mujoco": mujoco.__version__,
        "version.dm_control": importlib.metadata.version("dm-control"),
        "version.numpy": np.__version__,
        "version.python": platform.python_version(),
    }


def snapshot(physics: Any, prefix: str, state_path: Path | None) -> dict[str, float]:
    """Entanglement and contact metrics of the current state, keys prefixed; saves the state if asked.

    The saved .npz holds `curves` (F, n + 1, 3), `contact_points` (c, 3), `contact_kinds` (c,),
    `contact_forces_n` (c,) and the object's parts (`viz.pack`): the input of scripts/plot_entanglement.py.
    """
    curves = physics.centerlines()
    fields = local_fields(curves, LOCAL_ACN_DIAMETER_M)
    scene = physics.scene
    contacts = contact_summary(
        physics.model.ptr, physics.data.ptr, scene.filament_of_geom, scene.is_object_geom
    )
    row = {
        f"{prefix}.acn_total": acn_total(curves),
        f"{prefix}.local_acn_mean": fields.mean_acn,
        f"{prefix}.local_acn_max": fields.max_acn,
        f"{prefix}.local_count_mean": fields.mean_count,
    }
    row.update({f"{prefix}.contacts.{k}": v for k, v in contacts.counts.items()})
    if state_path is not None:
        atomic_save_npz(
            state_path,
            curves=curves,
            contact_points=contacts.points,
            contact_kinds=contacts.kinds,
            contact_forces_n=contacts.normal_forces_n,
            **pack(object_geometry(physics.model.ptr, physics.data.ptr, scene.is_object_geom)),
        )
    return row


def _simulate(
    spec: TrialSpec,
    limits: WatchdogLimits,
    inject_nan_at_s: float | None,
    state_dir: Path | None,
    recorder: TrialRecorder | None,
) -> dict[str, Any]:
    env = make_environment(spec.config, spec.seed)
    physics, task = env.physics, env.task
    model, data = physics.model.ptr, physics.data.ptr
    time_step = env.reset()
    fil = spec.config.gripper.filament
    kappa = fil.curvature_per_m(spec.config.gripper.pressure_pa)
    watchdog = Watchdog(
        model,
        data,
        limits,
        actuation_energy_j=spec.config.gripper.n_filaments * 0.5 * fil.bending_stiffness_nm2 * kappa**2 * fil.length_m,
    )
    schedule = task.schedule
    row: dict[str, Any] = {"outcome": "", "failure_mode": "", "unstable_reason": "", "unstable_time_s": None}
    taken = set()
    try:
        while not time_step.last():
            t = physics.time()
            if inject_nan_at_s is not None and t >= inject_nan_at_s:
                data.qvel[0] = np.nan
            time_step = env.step(scripted_action(spec.config, schedule, t))
            watchdog.check(model, data)
            phase = schedule.phase(physics.time() + 1e-9)
            if recorder is not None:
                recorder.maybe_record(physics.time(), physics, phase, task.pressure_pa)
            for name, when in (("actuated", "lift"), ("held", "release")):
                if phase == when and name not in taken:
                    taken.add(name)
                    path = None if state_dir is None else state_dir / f"{spec.trial_id}_{name}.npz"
                    row.update(snapshot(physics, name, path))
    except (WatchdogTripped, PhysicsError, mujoco.FatalError) as exc:
        # FatalError: MuJoCo aborted the step, e.g. an exploding state overflowed the constraint arena.
        reason = exc.reason if isinstance(exc, WatchdogTripped) else f"{type(exc).__name__}:{exc}"
        row.update(outcome="unstable", unstable_reason=reason, unstable_time_s=physics.time())
    if row["outcome"] != "unstable":
        success, mode = task.outcome.classify()
        row.update(outcome="success" if success else "failure", failure_mode=mode)
    row.update(
        lift_height_m=task.outcome.max_rise_m,
        hold_time_reached_s=task.outcome.hold_reached_s,
        sim_time_s=physics.time(),
    )
    return row


def run_trial(
    spec: TrialSpec,
    limits: WatchdogLimits | None = None,
    retry_unstable: bool = False,
    inject_nan_at_s: float | None = None,
    state_dir: Path | None = None,
    record_dir: Path | None = None,
) -> dict[str, Any]:
    """Run one trial and return its results row.

    With `retry_unstable`, an unstable trial is rerun once with half the timestep and the row says so.
    `inject_nan_at_s` corrupts the state at that time (for testing the watchdog). With `state_dir`, the
    filament and contact states at the end of actuation and of the hold are saved there as .npz; with
    `record_dir`, the whole trial is recorded there as `<trial_id>.mcap`.
    """
    start = time.perf_counter()
    limits = limits or WatchdogLimits()
    recorder = None
    if record_dir is not None:
        recorder = TrialRecorder(
            record_dir / f"{spec.trial_id}.mcap",
            metadata={"task": spec.task, "seed": str(spec.seed), "condition": spec.condition},
        )
    try:
        row = _simulate(spec, limits, inject_nan_at_s, state_dir, recorder)
    finally:
        if recorder is not None:
            recorder.close()
    retried = False
    if row["outcome"] == "unstable" and retry_unstable:
        numerics = dataclasses.replace(spec.config.numerics, timestep_s=spec.config.numerics.timestep_s / 2)
        halved = dataclasses.replace(spec, config=dataclasses.replace(spec.config, numerics=numerics))
        first_reason = row["unstable_reason"]
        row = _simulate(halved, limits, inject_nan_at_s, state_dir, None)
        row["first_unstable_reason"] = first_reason
        retried = True
    return {
        "trial_id": spec.trial_id,
        "task": spec.task,
        "condition": spec.condition,
        "seed": spec.seed,
        "preset": spec.preset,
        "success": row["outcome"] == "success",
        **dict(spec.params),
        **row,
        "retried_half_timestep": retried,
        "wall_time_s": time.perf_counter() - start,
        **versions(),
        **{f"config.{k}": v for k, v in to_flat_dict(spec.config).items()},
    }


class Executor(Protocol):
    """Runs a function over items, yielding results as they finish (any order)."""

    def map_unordered(self, fn: Callable[[Any], Any], items: list[Any]) -> Iterator[Any]:
        """Yield fn(item) for every item."""
        ...


class SerialExecutor:
    """Runs everything in this process (debugging, tests)."""

    def map_unordered(self, fn: Callable[[Any], Any], items: list[Any]) -> Iterator[Any]:
        """Yield fn(item) in order."""
        for item in items:
            yield fn(item)


class ProcessExecutor:
    """Local worker processes (one MuJoCo simulation per core)."""

    def __init__(self, workers: int):
        self.workers = workers

    def map_unordered(self, fn: Callable[[Any], Any], items: list[Any]) -> Iterator[Any]:
        """Yield results as workers finish them."""
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(self.workers, mp_context=context) as pool:
            futures = [pool.submit(fn, item) for item in items]
            try:
                for future in concurrent.futures.as_completed(futures):
                    yield future.result()
            except BaseException:
                for future in futures:
                    future.cancel()
                raise


def make_executor(workers: int) -> Executor:
    """Serial for one worker, local processes otherwise."""
    return SerialExecutor() if workers <= 1 else ProcessExecutor(workers)


def run_trials(
    specs: Iterable[TrialSpec],
    log: TrialLog,
    executor: Executor,
    retry_unstable: bool = False,
    progress: bool = True,
    record: bool = False,
) -> list[dict[str, Any]]:
    """Run every spec whose trial id is not yet in `log`, appending rows as they finish; return new rows."""
    specs = list(specs)
    done = log.done_ids()
    todo = [s for s in specs if s.trial_id not in done]
    bar = tqdm(
        total=len(specs),
        initial=len(specs) - len(todo),
        desc="trials",
        unit="trial",
        disable=not progress,
        file=sys.stderr,
    )
    rows, successes = [], 0
    folder = log.path.parent
    runner = _Runner(retry_unstable, folder / "states", folder / "recordings" if record else None)
    for row in executor.map_unordered(runner, todo):
        log.append(row)
        rows.append(row)
        successes += bool(row["success"])
        bar.update(1)
        bar.set_postfix(successes=successes, unstable=sum(r["outcome"] == "unstable" for r in rows))
    bar.close()
    return rows


@dataclass(frozen=True)
class _Runner:
    """Picklable callable for worker processes."""

    retry_unstable: bool
    state_dir: Path
    record_dir: Path | None

    def __call__(self, spec: TrialSpec) -> dict[str, Any]:
        return run_trial(
            spec, retry_unstable=self.retry_unstable, state_dir=self.state_dir, record_dir=self.record_dir
        )
