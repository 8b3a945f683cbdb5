"""Trial results on disk: an append-only JSON-lines log plus derived CSV tables.

Each finished trial is one line of `trials.jsonl`, written with a single `write` on a file opened with
O_APPEND under an exclusive lock and then fsynced, so a line is either whole or absent. A line cut off by a
crash (no trailing newline) is dropped when the log is next opened, and rows are de-duplicated by trial id,
so a rerun resumes an interrupted sweep, skips finished trials and never counts one twice. `trials.csv` and
`summary.csv` are rewritten atomically (temporary file + os.replace) from the log.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pandas as pd


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write `text` to `path` atomically (same-folder temporary file, fsync, os.replace)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as handle:
            handle.write(text)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_csv(frame: pd.DataFrame, path: str | os.PathLike) -> None:
    """Write a DataFrame as CSV atomically."""
    atomic_write_text(path, frame.to_csv(index=False))


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, tuple):
        return list(value)
    if hasattr(value, "item"):
        return value.item()
    return value


class TrialLog:
    """Append-only JSON-lines log of finished trials."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._repair()

    def _repair(self) -> None:
        """Drop a trailing partial line left by a crash mid-write."""
        if not self.path.exists():
            return
        with open(self.path, "rb+") as handle:
            fcntl.flock(handle, fcntl.LOCK_EX)
            data = handle.read()
            if data and not data.endswith(b"\n"):
                handle.truncate(data.rfind(b"\n") + 1)

    def rows(self) -> list[dict[str, Any]]:
        """All complete rows, first occurrence per trial id."""
        if not self.path.exists():
            return []
        seen, out = set(), []
        with open(self.path) as handle:
            for line in handle:
                if not line.endswith("\n"):
                    break
                row = json.loads(line)
                if row["trial_id"] not in seen:
                    seen.add(row["trial_id"])
                    out.append(row)
        return out

    def done_ids(self) -> set[str]:
        """Trial ids already in the log."""
        return {row["trial_id"] for row in self.rows()}

    def append(self, row: dict[str, Any]) -> None:
        """Append one row as a single atomic line."""
        line = (json.dumps({k: _jsonable(v) for k, v in row.items()}, sort_keys=True) + "\n").encode()
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            os.write(fd, line)
            os.fsync(fd)
        finally:
            os.close(fd)

    def frame(self) -> pd.DataFrame:
        """The log as a DataFrame (nested config flattened into columns)."""
        return pd.json_normalize(self.rows(), sep=".")

    def extend(self, rows: Iterable[dict[str, Any]]) -> None:
        """Append several rows."""
        for row in rows:
            self.append(row)
