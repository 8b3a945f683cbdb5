"""Trial recordings as MCAP files: time series of the scene state, viewable in Foxglove or read back here.

One channel `/trial/state` carries JSON messages (schema `entangle_bench.TrialState`) with the simulated
time (s), phase, pressure (Pa), hub position (m), object position (m) and quaternion, and the filament
centerlines (F, n + 1, 3) in m. Files are written to a temporary name and renamed when complete.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from mcap.reader import make_reader
from mcap.writer import Writer

TOPIC = "/trial/state"
SCHEMA = {
    "type": "object",
    "properties": {
        "time_s": {"type": "number"},
        "phase": {"type": "string"},
        "pressure_pa": {"type": "number"},
        "hub_position_m": {"type": "array", "items": {"type": "number"}},
        "object_position_m": {"type": "array", "items": {"type": "number"}},
        "object_quaternion": {"type": "array", "items": {"type": "number"}},
        "centerlines_m": {"type": "array"},
    },
}


class TrialRecorder:
    """Writes states of one trial at a fixed period; use as a context manager."""

    def __init__(self, path: str | os.PathLike, period_s: float = 0.05, metadata: dict[str, str] | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = self.path.with_name(f".{self.path.name}.tmp")
        self.period_s = period_s
        self._next = 0.0
        self._handle = open(self._tmp, "wb")
        self._writer = Writer(self._handle)
        self._writer.start(profile="", library="entangle-bench")
        schema = self._writer.register_schema(
            "entangle_bench.TrialState", "jsonschema", json.dumps(SCHEMA).encode()
        )
        self._channel = self._writer.register_channel(TOPIC, "json", schema)
        if metadata:
            self._writer.add_metadata("trial", dict(metadata))
        self._sequence = 0

    def maybe_record(self, time_s: float, physics: Any, phase: str, pressure_pa: float) -> None:
        """Record the state if a period has passed since the last record."""
        if time_s + 1e-12 < self._next:
            return
        self._next = time_s + self.period_s
        pos, quat = physics.object_pose()
        message = {
            "time_s": time_s,
            "phase": phase,
            "pressure_pa": pressure_pa,
            "hub_position_m": physics.hub_position().round(6).tolist(),
            "object_position_m": pos.round(6).tolist(),
            "object_quaternion": quat.round(6).tolist(),
            "centerlines_m": physics.centerlines().round(6).tolist(),
        }
        stamp = int(time_s * 1e9)
        self._writer.add_message(self._channel, stamp, json.dumps(message).encode(), stamp, self._sequence)
        self._sequence += 1

    def close(self, complete: bool = True) -> None:
        """Finish the file; keep it only if the trial completed (or ended as unstable)."""
        self._writer.finish()
        self._handle.close()
        if complete:
            os.replace(self._tmp, self.path)
        else:
            self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> TrialRecorder:
        return self

    def __exit__(self, exc_type: Any, *_: Any) -> None:
        self.close(complete=exc_type is None)


def read_recording(path: str | os.PathLike) -> Iterator[dict[str, Any]]:
    """Yield the recorded states of a trial in time order (centerlines as arrays)."""
    with open(path, "rb") as handle:
        for _, _, message in make_reader(handle).iter_messages(topics=[TOPIC]):
            state = json.loads(message.data)
            state["centerlines_m"] = np.asarray(state["centerlines_m"])
            yield state
