"""Observers of a running trial: recorders, writers and probes the runner calls around every control step.

An observer implements three methods (`Observer`); `runner.simulate(..., observers=[...])` calls

* `start(env)` once after the environment is reset, before the first step (and before the watchdog takes its
  reference energy, so a test observer may also set up an initial state);
* `step(env)` after every control step, once the watchdog has passed it;
* `finish(row, complete)` at the end, for every observer whose `start` was called: `complete` is True when the
  trial ran to its end or stopped as unstable (the row is final), False when an error interrupted it (discard
  partial output).

The harness's own observers write per-trial files: `recording.TrialRecorder` (Foxglove MCAP) and
`video.TrialVideo` (MP4). They hold open files and renderers, so they are made per trial inside the worker
(`runner.Watch.observers`), never pickled.
"""

from __future__ import annotations

from typing import Any, Protocol

from dm_control.rl import control


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
