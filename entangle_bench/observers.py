"""Observers of a running trial: recorders, writers and probes the runner calls around every control step.

An observer implements three methods (`Observer`); `runner.simulate(..., observers=[...])` calls

* `start(env)` once after the environment is reset, before the first step (and before the watchdog takes its
  reference energy, so a test observer may also set up an initial state);
* `step(env)` after every control step, once the watchdog has passed it;
* `finish(row, complete)` at the end: `complete` is True when the trial ran to its end or stopped as unstable
  (the row is final), False when an error interrupted it (discard partial output).

`McapObserver` records the scene state as MCAP (`entangle_bench.recording`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from dm_control.rl import control

from entangle_bench.recording import TrialRecorder


class Observer(Protocol):
    """Called by the runner after reset, after every control step, and at the end of a trial."""

    def start(self, env: control.Environment) -> None:
        """The environment has been reset; no step has run yet."""
        ...

    def step(self, env: control.Environment) -> None:
        """One control step has run and passed the watchdog."""
        ...

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """The trial is over: its row, and whether it ran to its end (or stopped as unstable)."""
        ...


class McapObserver:
    """Records a gripper trial's scene state every `period_s` (s) as `path` (MCAP, Foxglove-viewable)."""

    def __init__(self, path: Path, metadata: dict[str, str] | None = None, period_s: float = 0.05):
        self.path, self.metadata, self.period_s = Path(path), dict(metadata or {}), period_s
        self._recorder: TrialRecorder | None = None

    def start(self, env: control.Environment) -> None:
        """Open the recording."""
        self._recorder = TrialRecorder(self.path, self.period_s, self.metadata)

    def step(self, env: control.Environment) -> None:
        """Record the state if a period has passed."""
        physics, task = env.physics, env.task
        self._recorder.maybe_record(physics.time(), physics, task.phase(physics), task.pressure_pa)

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Close the file, keeping it only if the trial completed."""
        if self._recorder is not None:
            self._recorder.close(complete=complete)
            self._recorder = None
