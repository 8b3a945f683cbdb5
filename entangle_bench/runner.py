"""The trial runner: the one step loop, with the watchdog, for every task, study, probe and test.

A trial is (task, resolved configuration, seed). `simulate` builds the task's dm-control environment, drives
it with the task's scripted policy one control step at a time, checks the watchdog after every step, takes the
snapshots the task declares at the start of their phases, logs the task's per-step series, calls the
observers, and returns the results row with the final environment and watchdog. A trial the watchdog stops,
or one MuJoCo cannot continue (`PhysicsError`, `mujoco.FatalError`), is `unstable`, whatever the task had
decided: it is never scored. `run_trial` adds the trial's identity, configuration and versions to the row
(and can retry an unstable trial at half the timestep, and attach the recording and video observers that
`Watch` asks for). `run_trials` runs many through an executor (`entangle_bench.executors`: this process,
local worker processes, or Ray): each worker runs `TrialWorker`, which returns the row and the trial's files;
the driver writes the files, appends the row to the trial log, skips trials already in the log, and shows
progress.

Outcomes in a row: `success` and `failure` (the task's decision), `unstable` (stopped by the watchdog or
MuJoCo) and `failed` (the trial could not be run: its worker died on every attempt, or the trial raised;
`failed_reason` says which). Only success and failure are scored.
"""

from __future__ import annotations

import collections
import dataclasses
import hashlib
import importlib.metadata
import json
import os
import platform
import shutil
import socket
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from dm_control.rl import control
from dm_control.rl.control import PhysicsError
from tqdm import tqdm

import entangle_bench
from entangle_bench.atomic import AtomicFile, atomic_save_npz
from entangle_bench.config import to_flat_dict
from entangle_bench.errors import OutcomeError
from entangle_bench.executors import Executor, WorkerLost
from entangle_bench.observers import Observer
from entangle_bench.results import FAILED, SUCCESS, UNSTABLE, TrialLog
from entangle_bench.suite import TASKS
from entangle_bench.watchdog import Watchdog, WatchdogLimits, WatchdogStats, WatchdogTripped

#: Config fields added after results were logged, at the value that reproduces the behaviour from before them.
#: At that value a field stays out of the trial id, so the ids of those logs (and their resume) do not change.
ID_NEUTRAL_FIELDS: dict[str, Any] = {"contact.filament_friction": None, "gripper.filament.stretch_armature_ratio": 0.0}


def trial_id(task: str, config: Any, seed: int) -> str:
    """Stable 16-hex-digit id of (task, resolved configuration, seed)."""
    flat = {key: value for key, value in to_flat_dict(config).items()
            if not (key in ID_NEUTRAL_FIELDS and value == ID_NEUTRAL_FIELDS[key])}
    payload = json.dumps([task, flat, seed], sort_keys=True, default=repr)
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
        return self.row["outcome"] != UNSTABLE

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
    state_id: str | None = None,
) -> TrialResult:
    """Run one trial of a registered task with its scripted policy under the watchdog; return row and final state.

    `limits` replaces the task's watchdog limits. Observers see the environment after reset (before the
    watchdog takes its reference energy) and after every control step. With `state_dir`, snapshots and the
    task's per-step series are saved there as `<state_id>_<snapshot>.npz` and `<state_id>_series.npz`
    (`state_id`: default this trial's id).
    """
    env = TASKS.get(task).make_environment(config, seed)
    physics, bench_task = env.physics, env.task
    model, data = physics.model.ptr, physics.data.ptr
    trial = state_id or trial_id(task, config, seed)
    time_step = env.reset()
    row: dict[str, Any] = {"outcome": "", "failure_mode": "", "unstable_reason": "", "unstable_time_s": None}
    series: dict[str, list[float]] = {}
    taken: set[str] = set()
    started: list[Observer] = []
    complete = False
    try:
        for observer in observers:
            observer.start(env)
            started.append(observer)
        watchdog = Watchdog(model, data, limits or bench_task.watchdog_limits(), bench_task.actuation_energy_j())
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
                            atomic_save_npz(state_path(state_dir, trial, name), **snap.arrays)
        except (WatchdogTripped, PhysicsError, mujoco.FatalError) as exc:
            # FatalError: MuJoCo aborted the step, e.g. an exploding state overflowed the constraint arena.
            row.update(outcome=UNSTABLE, unstable_reason=_unstable_reason(exc), unstable_time_s=physics.time())
        if row["outcome"] != UNSTABLE:
            outcome = bench_task.outcome
            if outcome is None:
                raise OutcomeError(f"task {task} ended at t = {physics.time():.4f} s without deciding its outcome")
            row.update(outcome=outcome.status, failure_mode=outcome.failure_mode)
        row.update(bench_task.metrics(physics))
        row["sim_time_s"] = physics.time()
        row["max_penetration_m"] = watchdog.stats.max_penetration_m
        arrays = {name: np.asarray(values) for name, values in series.items()}
        if arrays and state_dir is not None:
            atomic_save_npz(state_path(state_dir, trial, "series"), **arrays)
        complete = True
    finally:
        for observer in started:
            observer.finish(row, complete)
    return TrialResult(row, env, watchdog, arrays)


@dataclass(frozen=True)
class Watch:
    """Which per-trial files the harness's observers write, and how often (s of simulated time).

    `record`: a Foxglove MCAP recording, `recordings/<trial_id>.mcap` (`recording.TrialRecorder`); `video`: an
    MP4, `videos/<trial_id>.mp4` (`video.TrialVideo`), `video_size` (width, height) in pixels.
    """

    record: bool = False
    record_period_s: float = 0.05
    video: bool = False
    video_period_s: float = 0.1
    video_size: tuple[int, int] = (640, 480)

    def observers(self, spec: TrialSpec, folder: Path, timestep_s: float) -> list[Observer]:
        """New observers of one run of a trial, at `timestep_s` (s), writing under `folder` (made per run: they
        hold files and renderers; the recording's metadata names the timestep, which a retry halves)."""
        out: list[Observer] = []
        if self.record:
            from entangle_bench.recording import TrialRecorder

            metadata = {"task": spec.task, "seed": str(spec.seed), "condition": spec.condition,
                        "trial_id": spec.trial_id, "timestep_s": repr(timestep_s)}
            out.append(TrialRecorder(folder / RECORDINGS / f"{spec.trial_id}.mcap", self.record_period_s, metadata))
        if self.video:
            from entangle_bench.video import TrialVideo

            out.append(TrialVideo(folder / VIDEOS / f"{spec.trial_id}.mp4", self.video_period_s, size=self.video_size))
        return out


#: Subfolders of a run's output folder that hold per-trial files.
STATES, RECORDINGS, VIDEOS = "states", "recordings", "videos"


def _identity(spec: TrialSpec) -> dict[str, Any]:
    """The row columns that say which trial a row is: id, task, condition, seed, preset, swept parameters."""
    return {
        "trial_id": spec.trial_id,
        "task": spec.task,
        "condition": spec.condition,
        "seed": spec.seed,
        "preset": spec.preset,
        **dict(spec.params),
    }


@dataclass(frozen=True)
class FirstAttempt:
    """An unstable first attempt of a trial, as a log records it: why and when (simulated s) it stopped, and
    its wall time (s)."""

    reason: str
    time_s: float
    wall_time_s: float

    @classmethod
    def of(cls, row: dict[str, Any]) -> FirstAttempt:
        """The first attempt a logged `unstable` row records."""
        return cls(row["unstable_reason"], row["unstable_time_s"], row.get("wall_time_s") or 0.0)


def run_trial(
    spec: TrialSpec,
    *,
    limits: WatchdogLimits | None = None,
    retry_unstable: bool = False,
    first_attempt: FirstAttempt | None = None,
    folder: Path | None = None,
    watch: Watch = Watch(),
    observers: Sequence[Observer] = (),
) -> dict[str, Any]:
    """Run one trial and return its results row (identity, outcome, metrics, snapshots, config, versions).

    With `retry_unstable`, an unstable trial is rerun once with half the timestep and the row says so;
    `first_attempt` (an unstable run a log already holds) goes straight to that retry, since a trial is
    deterministic and its first run would only repeat, and its wall time counts in the row's. With `folder`,
    the snapshots and series are saved under `folder/states/` and the files `watch` asks for under
    `folder/recordings/` and `folder/videos/`; a retry's saved states, recording and video replace the unstable
    run's under the trial's id, so they always show the run the row scores. `observers` (made once, by the
    caller) see the first run made.
    """
    start = time.perf_counter()
    state_dir = None if folder is None else Path(folder) / STATES

    def files(timestep_s: float) -> list[Observer]:
        return [] if folder is None else watch.observers(spec, Path(folder), timestep_s)

    first = first_attempt if retry_unstable else None
    logged_wall = 0.0 if first is None else first.wall_time_s
    retry_observers = [] if first is None else list(observers)  # the caller's see the first run made
    if first is None:
        row = simulate(spec.task, spec.config, spec.seed, limits=limits, state_dir=state_dir,
                       observers=[*observers, *files(spec.config.numerics.timestep_s)]).row
        if row["outcome"] == UNSTABLE and retry_unstable:
            first = FirstAttempt.of(row)
    retried = first is not None
    if retried:
        numerics = dataclasses.replace(spec.config.numerics, timestep_s=spec.config.numerics.timestep_s / 2)
        halved = dataclasses.replace(spec.config, numerics=numerics)
        if state_dir is not None:
            for stale in state_dir.glob(state_path(state_dir, spec.trial_id, "*").name):
                stale.unlink()
        row = simulate(spec.task, halved, spec.seed, limits=limits, state_dir=state_dir, state_id=spec.trial_id,
                       observers=[*retry_observers, *files(halved.numerics.timestep_s)]).row
        row.update(first_unstable_reason=first.reason, first_unstable_time_s=first.time_s)
    return {
        **_identity(spec),
        "success": row["outcome"] == SUCCESS,
        **row,
        "retried_half_timestep": retried,
        "wall_time_s": time.perf_counter() - start + logged_wall,
        **versions(),
        **{f"config.{k}": v for k, v in to_flat_dict(spec.config).items()},
    }


def failed_row(spec: TrialSpec, reason: str) -> dict[str, Any]:
    """The row of a trial that could not be run (outcome `failed`, never scored), with the reason."""
    return {
        **_identity(spec),
        "success": False,
        "outcome": FAILED,
        "failure_mode": "",
        "unstable_reason": "",
        "failed_reason": reason,
        **versions(),
        **{f"config.{k}": v for k, v in to_flat_dict(spec.config).items()},
    }


TRIAL_SCRATCH = "entangle-bench-trial-"
"""Prefix of a trial's scratch folder, '<prefix><pid>@<host>-<random>', in its process's temporary folder."""


def _alive(pid: int) -> bool:
    """Whether process `pid` exists on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def trial_scratch() -> tempfile.TemporaryDirectory[str]:
    """A private scratch folder for one trial, named after this process and machine.

    First it removes the scratch folders that processes of this machine left when they died mid-trial: a
    killed Ray worker cannot clean up, and its driver does not know the folder, so the next trial on the same
    node does it. Folders of live processes and of other machines (a shared temporary folder) are left alone.
    """
    host = socket.gethostname()
    for path in Path(tempfile.gettempdir()).glob(f"{TRIAL_SCRATCH}*@*-*"):
        owner = path.name[len(TRIAL_SCRATCH):].rsplit("-", 1)[0]
        pid, _, owner_host = owner.partition("@")
        if owner_host == host and pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(path, ignore_errors=True)
    return tempfile.TemporaryDirectory(prefix=f"{TRIAL_SCRATCH}{os.getpid()}@{host}-")


@dataclass(frozen=True, eq=False)
class TrialOutput:
    """What a worker hands back for one trial: its row and the files it wrote, for the driver to store."""

    row: dict[str, Any]
    files: dict[str, bytes] = field(default_factory=dict)
    """Path relative to the output folder ('states/<id>_held.npz', ...) -> content."""


@dataclass(frozen=True)
class TrialWorker:
    """The function executors run on a TrialSpec, in any process or on any machine: picklable.

    It runs the trial in a private scratch folder and returns the row with every file the trial wrote
    (`TrialOutput`), so only the driver writes into the output folder, which need not be shared with the
    workers. An exception raised by the trial (a bug, not a physical instability) becomes a `failed` row
    with the exception as its reason; it is not retried, since it would recur.
    """

    retry_unstable: bool = False
    watch: Watch = Watch()
    observers: Callable[[TrialSpec], Sequence[Observer]] | None = None
    """Extra observers made per trial (test probes); must be picklable."""
    first_attempts: Mapping[str, FirstAttempt] = field(default_factory=dict)
    """Unstable first attempts a log already holds, by trial id: with `retry_unstable` those trials go
    straight to the retry."""

    def __call__(self, spec: TrialSpec) -> TrialOutput:
        extra = list(self.observers(spec)) if self.observers is not None else []
        with trial_scratch() as scratch:
            folder = Path(scratch)
            try:
                row = run_trial(spec, retry_unstable=self.retry_unstable,
                                first_attempt=self.first_attempts.get(spec.trial_id), folder=folder,
                                watch=self.watch, observers=extra)
            except Exception as exc:  # any bug in any task: record it and go on with the sweep
                return TrialOutput(failed_row(spec, f"error: {type(exc).__name__}: {exc}"))
            files = {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
                     if p.is_file()}
        return TrialOutput(row, files)


def run_trials(
    specs: Iterable[TrialSpec],
    log: TrialLog,
    executor: Executor,
    *,
    retry_unstable: bool = False,
    progress: bool = True,
    watch: Watch = Watch(),
    observers: Callable[[TrialSpec], Sequence[Observer]] | None = None,
) -> list[dict[str, Any]]:
    """Run every spec whose trial id is not yet in `log` (or only as failed, or with `retry_unstable` only as
    `unstable` without a retry: that one goes straight to the retry at half the timestep, whose row then
    replaces it); return the new rows.

    The driver alone writes: for each trial, as it finishes, its files into the log's folder (atomically),
    then its row into the log, so a logged row always has its files. A trial whose worker died on every
    attempt the executor allows is logged as `failed` with the reason (`failed_row`) and run again by the
    next rerun. `observers` makes extra observers per trial (see `TrialWorker`).
    """
    specs = list(specs)
    done, logged = log.resume_state(retry_unstable)
    todo = [s for s in specs if s.trial_id not in done]
    bar = tqdm(
        total=len(specs),
        initial=len(specs) - len(todo),
        desc="trials",
        unit="trial",
        disable=not progress,
        file=sys.stderr,
    )
    rows: list[dict[str, Any]] = []
    folder = log.path.parent
    first_attempts = {s.trial_id: FirstAttempt.of(logged[s.trial_id]) for s in todo if s.trial_id in logged}
    worker = TrialWorker(retry_unstable, watch, observers, first_attempts)
    for spec, result in executor.map_unordered(worker, todo):
        if isinstance(result, WorkerLost):
            result = TrialOutput(failed_row(spec, result.reason))
        for name, content in result.files.items():
            with AtomicFile(folder / name) as out:
                out.tmp.write_bytes(content)
        log.append(result.row)
        rows.append(result.row)
        bar.update(1)
        outcomes = collections.Counter(r["outcome"] for r in rows)
        bar.set_postfix(successes=outcomes[SUCCESS], unstable=outcomes[UNSTABLE], failed=outcomes[FAILED])
    bar.close()
    return rows
