"""The trial runner: the one step loop, with the watchdog, for every task, study, probe and test.

A trial is (task, resolved configuration, seed). `simulate` builds the task's dm-control environment, drives
it with the task's scripted policy one control step at a time, checks the watchdog after every step, takes the
snapshots the task declares at the start of their phases, logs the task's per-step series, calls the
observers, and returns the results row with the final environment and watchdog. A trial the watchdog stops,
or one MuJoCo cannot continue (`PhysicsError`, `mujoco.FatalError`), is `unstable`, whatever the task had
decided: it is never scored. `run_trial` adds the trial's identity, configuration and versions to the row
(and can retry an unstable trial at half the timestep); `run_trials` runs many through an `Executor` (local
worker processes by default), appends each finished row to the trial log at once, skips trials already in the
log, and shows progress.
"""

from __future__ import annotations

import concurrent.futures
import dataclasses
import hashlib
import importlib.metadata
import json
import multiprocessing
import os
import platform
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.rl.control import PhysicsError
from tqdm import tqdm

import entangle_bench
from entangle_bench.config import to_flat_dict
from entangle_bench.errors import OutcomeError
from entangle_bench.observers import McapObserver, Observer
from entangle_bench.results import TrialLog
from entangle_bench.suite import TASKS
from entangle_bench.watchdog import Watchdog, WatchdogLimits, WatchdogStats, WatchdogTripped


def trial_id(task: str, config: Any, seed: int) -> str:
    """Stable 16-hex-digit id of (task, resolved configuration, seed)."""
    payload = json.dumps([task, to_flat_dict(config), seed], sort_keys=True, default=repr)
    return hashlib.sha1(payload.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class TrialSpec:
    """One trial to run: a registered task, its resolved config (the task's config type) and a seed."""

    task: str
    """'domain/name' of a registered task."""
    condition: str
    config: Any
    seed: int
    preset: str
    params: tuple[tuple[str, Any], ...] = ()
    """The condition's swept parameters (name, value), copied into the row for grouping."""

    @property
    def trial_id(self) -> str:
        """Stable id of (task, resolved configuration, seed)."""
        return trial_id(self.task, self.config, self.seed)


@dataclass(frozen=True, eq=False)
class TrialResult:
    """What `simulate` returns: the row, and the final environment, watchdog and per-step series."""

    row: dict[str, Any]
    env: control.Environment
    watchdog: Watchdog
    series: dict[str, np.ndarray] = field(default_factory=dict)
    """Per-control-step values the task logged (`BenchTask.series_point`), with `time_s`."""

    @property
    def stable(self) -> bool:
        """Whether the trial ran to its end without the watchdog or MuJoCo stopping it."""
        return self.row["outcome"] != "unstable"

    @property
    def reason(self) -> str:
        """Why the trial was unstable ('' if stable)."""
        return self.row["unstable_reason"]

    @property
    def time_s(self) -> float:
        """Simulated time reached (the stop time if unstable), s."""
        return self.row["sim_time_s"]

    @property
    def stats(self) -> WatchdogStats:
        """The watchdog's worst values."""
        return self.watchdog.stats


def versions() -> dict[str, str]:
    """Software versions recorded with every row."""
    return {
        "version.entangle_bench": entangle_bench.__version__,
        "version.mujoco": mujoco.__version__,
        "version.dm_control": importlib.metadata.version("dm-control"),
        "version.numpy": np.__version__,
        "version.python": platform.python_version(),
    }


def state_path(state_dir: str | os.PathLike, trial: str, name: str) -> Path:
    """Where a trial's saved state `name` (a snapshot, or 'series') lies: `<state_dir>/<trial_id>_<name>.npz`."""
    return Path(state_dir) / f"{trial}_{name}.npz"


def _save_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write arrays to `path` as compressed .npz, atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, path)


def _unstable_reason(exc: BaseException) -> str:
    """One-line reason of an unstable trial."""
    return exc.reason if isinstance(exc, WatchdogTripped) else f"{type(exc).__name__}:{exc}"


def simulate(
    task: str,
    config: Any,
    seed: int,
    *,
    limits: WatchdogLimits | None = None,
    observers: Sequence[Observer] = (),
    state_dir: Path | None = None,
) -> TrialResult:
    """Run one trial of a registered task with its scripted policy under the watchdog; return row and final state.

    `limits` replaces the task's watchdog limits. Observers see the environment after reset (before the
    watchdog takes its reference energy) and after every control step. With `state_dir`, snapshots and the
    task's per-step series are saved there as `<trial_id>_<snapshot>.npz` and `<trial_id>_series.npz`.
    """
    env = TASKS.get(task).make_environment(config, seed)
    physics, bench_task = env.physics, env.task
    model, data = physics.model.ptr, physics.data.ptr
    trial = trial_id(task, config, seed)
    time_step = env.reset()
    for observer in observers:
        observer.start(env)
    watchdog = Watchdog(model, data, limits or bench_task.watchdog_limits(), bench_task.actuation_energy_j())
    row: dict[str, Any] = {"outcome": "", "failure_mode": "", "unstable_reason": "", "unstable_time_s": None}
    series: dict[str, list[float]] = {}
    taken: set[str] = set()
    complete = False
    try:
        try:
            while not time_step.last():
                time_step = env.step(bench_task.scripted_action(physics))
                watchdog.check(model, data)
                for observer in observers:
                    observer.step(env)
                point = bench_task.series_point(physics)
                if point:
                    for name, value in {"time_s": physics.time(), **point}.items():
                        series.setdefault(name, []).append(value)
                phase = bench_task.phase(physics)
                for name, when in bench_task.SNAPSHOTS.items():
                    if phase == when and name not in taken:
                        taken.add(name)
                        snap = bench_task.snapshot(physics)
                        row.update({f"{name}.{k}": v for k, v in snap.metrics.items()})
                        if state_dir is not None:
                            _save_npz(state_path(state_dir, trial, name), snap.arrays)
        except (WatchdogTripped, PhysicsError, mujoco.FatalError) as exc:
            # FatalError: MuJoCo aborted the step, e.g. an exploding state overflowed the constraint arena.
            row.update(outcome="unstable", unstable_reason=_unstable_reason(exc), unstable_time_s=physics.time())
        if row["outcome"] != "unstable":
            outcome = bench_task.outcome
            if outcome is None:
                raise OutcomeError(f"task {task} ended at t = {physics.time():.4f} s without deciding its outcome")
            row.update(outcome=outcome.status, failure_mode=outcome.failure_mode)
        row.update(bench_task.metrics(physics))
        row["sim_time_s"] = physics.time()
        arrays = {name: np.asarray(values) for name, values in series.items()}
        if arrays and state_dir is not None:
            _save_npz(state_path(state_dir, trial, "series"), arrays)
        complete = True
    finally:
        for observer in observers:
            observer.finish(row, complete)
    return TrialResult(row, env, watchdog, arrays)


def run_trial(
    spec: TrialSpec,
    *,
    limits: WatchdogLimits | None = None,
    retry_unstable: bool = False,
    state_dir: Path | None = None,
    record_dir: Path | None = None,
    observers: Sequence[Observer] = (),
) -> dict[str, Any]:
    """Run one trial and return its results row (identity, outcome, metrics, snapshots, config, versions).

    With `retry_unstable`, an unstable trial is rerun once with half the timestep (without observers) and
    the row says so. With `state_dir`, the snapshots are saved there as .npz; with `record_dir`, the whole
    trial is recorded there as `<trial_id>.mcap` (`observers.McapObserver`).
    """
    start = time.perf_counter()
    watchers = list(observers)
    if record_dir is not None:
        metadata = {"task": spec.task, "seed": str(spec.seed), "condition": spec.condition}
        watchers.append(McapObserver(Path(record_dir) / f"{spec.trial_id}.mcap", metadata))
    row = simulate(spec.task, spec.config, spec.seed, limits=limits, observers=watchers, state_dir=state_dir).row
    retried = False
    if row["outcome"] == "unstable" and retry_unstable:
        numerics = dataclasses.replace(spec.config.numerics, timestep_s=spec.config.numerics.timestep_s / 2)
        halved = dataclasses.replace(spec.config, numerics=numerics)
        first_reason = row["unstable_reason"]
        row = simulate(spec.task, halved, spec.seed, limits=limits, state_dir=state_dir).row
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
