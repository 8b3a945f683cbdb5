"""Stopping a `run --workers 2` with SIGINT or SIGTERM: workers stopped, message, exit code, a consistent log."""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from entangle_bench.suite import SHORT_SEQUENCE

TRIALS = 40  # far more than run before the signal: the run cannot finish first


def _children(pid: int) -> set[int]:
    """Ids of the direct child processes of `pid` (Linux /proc)."""
    out: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return out


def _descendants(pid: int) -> set[int]:
    """Ids of every process below `pid`."""
    out, todo = set(), [pid]
    while todo:
        new = _children(todo.pop()) - out
        out |= new
        todo += new
    return out


def _rows(log: Path) -> list[dict]:
    if not log.exists():
        return []
    return [json.loads(line) for line in log.read_text().splitlines()]


def _wait(condition, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.05)


@pytest.mark.skipif(not Path("/proc/self/task").exists(), reason="reads child processes from Linux /proc")
@pytest.mark.parametrize(("signum", "code", "executor"), [
    (signal.SIGINT, 130, "local"),
    (signal.SIGTERM, 143, "local"),
    pytest.param(signal.SIGINT, 130, "ray", marks=pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                                                                      reason="needs ray")),
])
def test_a_signal_stops_the_workers_and_keeps_the_log_whole(tmp_path, signum, code, executor):
    """Local: the two worker processes end. Ray: the local Ray instance the run started (its daemons and workers)
    is shut down."""
    out = tmp_path / "out"
    argv = [sys.executable, "-m", "entangle_bench.cli", "run", "sphere", "--trials", str(TRIALS), "--workers", "2",
            "--preset", "fast", "--out", str(out), "--no-progress", "--executor", executor]
    argv += [a for s in SHORT_SEQUENCE for a in ("--set", s)]
    env = dict(os.environ, RAY_AUTH_MODE="disabled")  # a local Ray instance for seconds: no token file in ~/.ray
    # SIGINT at its default disposition in the driver even where this test runs with it ignored (a background
    # job of a non-interactive shell), which Python would otherwise keep.
    driver = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                              env=env, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        log = out / "trials.jsonl"
        # two workers (and multiprocessing's resource tracker), and one trial done, so both workers are busy
        _wait(lambda: len(_rows(log)) >= 1 and len(_children(driver.pid)) >= 2, 240, "two workers and a row")
        workers = _descendants(driver.pid)
        driver.send_signal(signum)
        stdout, stderr = driver.communicate(timeout=60)
    finally:
        if driver.poll() is None:
            os.killpg(driver.pid, signal.SIGKILL)
            driver.wait()
    assert driver.returncode == code, stderr
    name = signal.Signals(signum).name
    assert f"entangle-bench: interrupted ({name})" in stderr and "run interrupted:" in stderr
    assert "Traceback" not in stderr
    _wait(lambda: not any(Path(f"/proc/{pid}").exists() for pid in workers), 10, "the child processes to be gone")
    lines = log.read_text().splitlines(keepends=True)
    assert all(line.endswith("\n") for line in lines)
    ids = [json.loads(line)["trial_id"] for line in lines]
    assert 1 <= len(ids) < TRIALS and len(set(ids)) == len(ids)
    assert f"{len(ids)} of {TRIALS} trials are in" in stderr
    states = {p.name.split("_")[0] for p in (out / "states").glob("*.npz")}
    assert set(ids) <= states  # every logged trial has its states (the driver writes files, then the row)
