"""Executors: local processes and Ray give the rows, files and resume of a serial run; dead workers are retried
once, then logged as failed. Ray runs on one local instance (2 CPUs) started by this module."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.cli import main
from entangle_bench.executors import ProcessExecutor, RayExecutor, SerialExecutor, make_executor
from entangle_bench.metrics.stats import success_table
from entangle_bench.results import FAILED, TrialLog
from entangle_bench.runner import TRIAL_SCRATCH, run_trials, trial_scratch
from entangle_bench.suite import SHORT_SEQUENCE

#: Columns that must not depend on where a trial ran.
SAME = ("trial_id", "task", "condition", "seed", "preset", "outcome", "failure_mode", "sim_time_s", "lift_clearance_m",
        "actuated.acn_total", "held.acn_total", "held.contacts.filament-object", "config.gripper.pressure_pa")


@pytest.fixture(scope="module")
def ray_cluster():
    """One local Ray instance with 2 CPUs for the whole module; this module's observers travel by value.

    Token authentication is off for this short-lived local instance, so Ray writes no ~/.ray/auth_token.
    """
    ray = pytest.importorskip("ray")  # imported here, not by the worker processes that import this module
    handler = signal.getsignal(signal.SIGTERM)  # ray.init replaces it: restore it afterwards
    mode = os.environ.get("RAY_AUTH_MODE")
    os.environ["RAY_AUTH_MODE"] = "disabled"
    try:
        ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
        yield
    finally:
        ray.shutdown()
        signal.signal(signal.SIGTERM, handler)
        if mode is None:
            os.environ.pop("RAY_AUTH_MODE", None)
        else:
            os.environ["RAY_AUTH_MODE"] = mode


@pytest.fixture
def specs(short_spec):
    return [short_spec("sphere", seed) for seed in (0, 1)]


@dataclass(frozen=True)
class Dies:
    """Observer factory: a trial's worker process exits (os._exit) at 0.1 s simulated on its first
    `times[trial_id]` attempts; each attempt leaves a file `<trial_id>.<n>` in `folder` to count them by,
    holding the worker's process id and temporary folder."""

    folder: Path
    times: dict[str, int]

    def __call__(self, spec):
        return [_Dying(self.folder, spec.trial_id, self.times.get(spec.trial_id, 0))]


class _Dying:
    def __init__(self, folder, trial_id, times):
        self.folder, self.trial_id, self.times = Path(folder), trial_id, times

    def start(self, env):
        self.attempt = len(list(self.folder.glob(f"{self.trial_id}.*")))
        (self.folder / f"{self.trial_id}.{self.attempt}").write_text(f"{os.getpid()} {tempfile.gettempdir()}")

    def step(self, env):
        if self.attempt < self.times and env.physics.time() >= 0.1:
            os._exit(3)

    def finish(self, row, complete):
        pass


def test_ray_rows_and_files_are_those_of_a_serial_run_and_resume_skips_done_trials(tmp_path, specs, ray_cluster):
    serial = {r["trial_id"]: r for r in run_trials(specs, TrialLog(tmp_path / "s" / "trials.jsonl"),
                                                   SerialExecutor(), progress=False)}
    log = TrialLog(tmp_path / "r" / "trials.jsonl")
    log.append(serial[specs[0].trial_id])  # the first trial is already done
    rows = run_trials(specs, log, RayExecutor(), progress=False)
    assert [r["trial_id"] for r in rows] == [specs[1].trial_id]  # only the missing trial ran
    for row in log.rows():
        assert {k: row[k] for k in SAME} == {k: serial[row["trial_id"]][k] for k in SAME}
    name = f"states/{specs[1].trial_id}_held.npz"
    with np.load(tmp_path / "s" / name) as a, np.load(tmp_path / "r" / name) as b:
        assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files)
    assert run_trials(specs, log, RayExecutor(), progress=False) == []


@pytest.mark.parametrize("kind", ["processes", "ray"])
def test_a_worker_killed_once_is_retried_and_one_killed_twice_is_a_failed_row_never_scored(tmp_path, specs, kind,
                                                                                            request):
    """Two trials at once: the first trial's worker dies once (rerun, row as usual), the second's twice."""
    if kind == "ray":
        request.getfixturevalue("ray_cluster")
        executor = RayExecutor()
    else:
        executor = ProcessExecutor(2)
    once, twice = (s.trial_id for s in specs)
    log = TrialLog(tmp_path / "trials.jsonl")
    rows = {r["trial_id"]: r for r in run_trials(specs, log, executor, progress=False,
                                                 observers=Dies(tmp_path, {once: 1, twice: 2}))}
    assert rows[once]["outcome"] in ("success", "failure") and rows[once]["sim_time_s"] > 1.0
    assert len(list(tmp_path.glob(f"{once}.*"))) == 2 and len(list(tmp_path.glob(f"{twice}.*"))) == 2
    failed = rows[twice]
    assert failed["outcome"] == FAILED and failed["success"] is False
    assert "died" in failed["failed_reason"] and "on each of 2 attempts" in failed["failed_reason"]
    assert failed["config.gripper.pressure_pa"] == specs[1].config.gripper.pressure_pa  # a full identity row
    summary = success_table(log.frame(), ["condition"]).iloc[0]
    assert (summary["trials"], summary["failed"]) == (2, 1)
    succeeded = float(rows[once]["outcome"] == "success")
    assert summary["success_rate"] == succeeded  # the rate is over the one scored trial
    assert log.done_ids() == {once}  # a failed trial is not done: the rerun runs it, and its row replaces it
    (again,) = run_trials(specs, log, SerialExecutor(), progress=False)
    assert again["trial_id"] == twice and again["outcome"] != FAILED
    assert sorted(r["outcome"] != FAILED for r in log.rows()) == [True, True]
    # The dead attempts' trial scratch folders are gone: a later trial on the machine removed them.
    attempts = {tuple(p.read_text().split(" ", 1)) for p in tmp_path.glob("*.*") if p.suffix[1:].isdigit()}
    assert not [p for pid, temporary in attempts for p in Path(temporary).glob(f"{TRIAL_SCRATCH}{pid}@*")]


def test_cli_runs_on_ray_and_refuses_bad_executor_settings(tmp_path, capsys, ray_cluster):
    argv = ["run", "sphere", "--trials", "2", "--preset", "fast", "--out", str(tmp_path), "--no-progress",
            *[a for s in SHORT_SEQUENCE for a in ("--set", s)]]
    assert main([*argv, "--executor", "ray"]) == 0
    assert len(TrialLog(tmp_path / "trials.jsonl").rows()) == 2 and (tmp_path / "trials.parquet").exists()
    assert main([*argv, "--executor", "slurm"]) == 2
    assert "executor 'slurm' is not one of ['local', 'ray']" in capsys.readouterr().err
    with pytest.raises(Exception, match="--address is for --executor ray"):
        make_executor(2, "local", "auto")


def test_a_trial_removes_the_scratch_folders_of_dead_processes_on_its_machine_only(tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    gone = subprocess.Popen(["true"])
    gone.wait()
    host = socket.gethostname()
    names = {"dead": f"{gone.pid}@{host}-abc", "live": f"{os.getpid()}@{host}-abc",
             "elsewhere": f"{gone.pid}@not-{host}-abc"}
    for name in names.values():
        (tmp_path / f"{TRIAL_SCRATCH}{name}").mkdir()
        (tmp_path / f"{TRIAL_SCRATCH}{name}" / "states").mkdir()
    with trial_scratch() as scratch:
        assert Path(scratch).name.startswith(f"{TRIAL_SCRATCH}{os.getpid()}@{host}-")
        left = {p.name[len(TRIAL_SCRATCH):] for p in tmp_path.iterdir()}
    assert left == {names["live"], names["elsewhere"], Path(scratch).name[len(TRIAL_SCRATCH):]}


def _temp_file_then_die(folder: str) -> None:
    """Make a temporary file the usual way, note its path in `folder`, and die as a killed worker would."""
    import tempfile

    handle, path = tempfile.mkstemp()
    os.close(handle)
    Path(folder, f"{os.getpid()}.path").write_text(path)
    os._exit(3)


def test_a_killed_worker_leaves_no_temporary_files(tmp_path):
    """A worker's temporary files lie in a folder the driver removes with the process, even when it dies."""
    ((_, lost),) = list(ProcessExecutor(1, attempts=2).map_unordered(_temp_file_then_die, [str(tmp_path)]))
    assert "died" in lost.reason
    paths = [Path(p.read_text()) for p in tmp_path.glob("*.path")]
    assert len(paths) == 2  # one per attempt, each in a fresh worker
    assert all(p.parent.name.startswith("entangle-bench-worker-") for p in paths)
    assert not any(p.exists() or p.parent.exists() for p in paths)
