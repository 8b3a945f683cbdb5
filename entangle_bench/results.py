"""Trial results on disk: an append-only JSON-lines log plus derived typed tables (CSV and Parquet).

Each finished trial is one line of `trials.jsonl`, written with a single `write` on a file opened with
O_APPEND while holding the log's lock (`filelock`, file `trials.jsonl.lock`) and then fsynced, so a line is
either whole or absent. A line cut off by a crash (no trailing newline) is dropped when the log is next
opened, and rows are de-duplicated by trial id, so a rerun resumes an interrupted sweep, skips finished
trials and never counts one twice. A trial that could not be run is logged with outcome `failed` (`FAILED`)
so that it is never lost silently; it is not finished: a rerun runs it again, and its first row of any other
outcome replaces the failed one.

`trials.csv` (for people and spreadsheets) and `trials.parquet` (typed, compact and fast for sweeps of
10^4-10^6 rows) are rewritten atomically from the log. Every column is bool, int64, float64 or string
(`typed`): lists and dicts become JSON text, a missing string is "", a missing number NaN (or <NA> in an
integer or bool column). `read_results` reads any of the three files, or a results folder, into that
typed frame. A CSV cannot tell an empty string from a missing number: a column with no value in any row
reads as float NaN, unless its name is a known text column (`TEXT_COLUMNS`, `version.*`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from filelock import FileLock

from entangle_bench.atomic import AtomicFile, atomic_write_text
from entangle_bench.errors import FileFormatError

LOG_NAME, CSV_NAME, PARQUET_NAME = "trials.jsonl", "trials.csv", "trials.parquet"
#: Outcome of a trial that could not be run (its worker died on every attempt, or it raised); never scored.
FAILED = "failed"
#: Outcome of a trial the watchdog stopped or MuJoCo could not continue; never scored.
UNSTABLE = "unstable"
#: Outcomes a task decided (`suite.base.Outcome.status`): the only ones a success rate or toughness scores.
SUCCESS, FAILURE = "success", "failure"
SCORED = (SUCCESS, FAILURE)
#: Result columns that hold text even when every row leaves them empty.
TEXT_COLUMNS = frozenset(
    {"trial_id", "task", "condition", "preset", "outcome", "failure_mode", "unstable_reason",
     "first_unstable_reason", "failed_reason"}
)


def atomic_write_csv(frame: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Write a DataFrame as CSV atomically; return the path."""
    return atomic_write_text(path, frame.to_csv(index=False))


def _is_text_column(name: str) -> bool:
    return name in TEXT_COLUMNS or name.startswith("version.")


def _typed_column(name: str, column: pd.Series) -> pd.Series:
    """One column as bool / int64 / float64 / string (nullable variants where values are missing)."""
    missing = column.isna()
    if missing.all():
        return pd.Series("" if _is_text_column(name) else math.nan, index=column.index,
                         dtype="string" if _is_text_column(name) else "float64")
    kind = pd.api.types.infer_dtype(column, skipna=True)
    missing = bool(missing.any())
    if kind == "boolean":
        return column.astype("boolean" if missing else bool)
    if kind == "integer":
        return column.astype("Int64" if missing else "int64")
    if kind in ("floating", "mixed-integer-float", "decimal"):
        return column.astype("Float64").astype("float64")
    if kind != "string":  # lists, dicts, mixed values: JSON text
        column = column.map(lambda v: v if isinstance(v, str) or _missing(v) else json.dumps(v))
    return column.astype("string").fillna("")


def _missing(value: Any) -> bool:
    return value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value))


def typed(frame: pd.DataFrame) -> pd.DataFrame:
    """The frame with every column bool, int64, float64 or string (never object); see the module doc."""
    return pd.DataFrame({name: _typed_column(str(name), frame[name]) for name in frame.columns},
                        index=frame.index)


def write_parquet(frame: pd.DataFrame, path: str | os.PathLike) -> Path:
    """Write a typed frame as Parquet atomically; return the path."""
    table = pa.Table.from_pandas(typed(frame), preserve_index=False)
    with AtomicFile(path) as out:
        pq.write_table(table, out.tmp)
    return out.path


def write_trials(rows: pd.DataFrame, folder: str | os.PathLike) -> tuple[Path, Path]:
    """Write `trials.csv` and `trials.parquet` (typed) into `folder`; return both paths."""
    frame = typed(rows)
    folder = Path(folder)
    return atomic_write_csv(frame, folder / CSV_NAME), write_parquet(frame, folder / PARQUET_NAME)


def read_results(path: str | os.PathLike) -> pd.DataFrame:
    """Typed trial rows from `trials.parquet`, `trials.csv`, `trials.jsonl` or a results folder.

    A folder is read from its Parquet file, else its CSV, else its log.
    """
    path = Path(path)
    if path.is_dir():
        for name in (PARQUET_NAME, CSV_NAME, LOG_NAME):
            if (path / name).is_file():
                return read_results(path / name)
        raise FileFormatError(f"{path}: no {PARQUET_NAME}, {CSV_NAME} or {LOG_NAME} in this folder")
    if not path.is_file():
        raise FileFormatError(f"{path}: no such results file or folder")
    suffix = path.suffix.lower()
    try:
        if suffix == ".parquet":
            frame = pq.read_table(path).to_pandas()
        elif suffix == ".csv":
            frame = pd.read_csv(path, dtype_backend="numpy_nullable")
        elif suffix == ".jsonl":
            frame = pd.json_normalize(read_log(path), sep=".")
        else:
            raise FileFormatError(f"{path}: results are read from .parquet, .csv or .jsonl files")
    except (pa.ArrowException, pd.errors.ParserError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"{path}: not a readable {suffix} results file: {exc}") from None
    return typed(frame)


def _jsonable(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, tuple):
        return list(value)
    if hasattr(value, "item"):
        return value.item()
    return value


def read_log(path: str | os.PathLike) -> list[dict[str, Any]]:
    """All complete rows of a trial log, one per trial id (a torn last line is skipped).

    A trial's row is its first one, unless a later one supersedes it (`_supersedes`): a rerun that ran a
    failed trial, or retried an `unstable` one at half the timestep, replaces its row.
    """
    path = Path(path)
    if not path.exists():
        return []
    rows: dict[str, dict[str, Any]] = {}
    with open(path) as handle:
        for line in handle:
            if not line.endswith("\n"):
                break
            row = json.loads(line)
            first = rows.get(row["trial_id"])
            if first is None or _supersedes(row, first):
                rows[row["trial_id"]] = row
    return list(rows.values())


def _needs_retry(row: dict[str, Any]) -> bool:
    """Whether a row is `unstable` and was not yet retried at half the timestep."""
    return row.get("outcome") == UNSTABLE and not row.get("retried_half_timestep")


def _supersedes(later: dict[str, Any], first: dict[str, Any]) -> bool:
    """Whether a later row of a trial replaces its first: a run of a failed trial, or the retry of an unstable one."""
    if first.get("outcome") == FAILED:
        return later.get("outcome") != FAILED
    return _needs_retry(first) and bool(later.get("retried_half_timestep"))


class TrialLog:
    """Append-only JSON-lines log of finished trials."""

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = FileLock(self.path.with_name(self.path.name + ".lock"))
        self._repair()

    def _repair(self) -> None:
        """Drop a trailing partial line left by a crash mid-write."""
        if not self.path.exists():
            return
        with self._lock, open(self.path, "rb+") as handle:
            data = handle.read()
            if data and not data.endswith(b"\n"):
                handle.truncate(data.rfind(b"\n") + 1)

    def rows(self) -> list[dict[str, Any]]:
        """All complete rows, one per trial id (`read_log`: the first, unless a later one supersedes it)."""
        return read_log(self.path)

    def done_ids(self, retry_unstable: bool = False) -> set[str]:
        """Ids of the trials the log holds a result of (see `resume_state`)."""
        return self.resume_state(retry_unstable)[0]

    def resume_state(self, retry_unstable: bool = False) -> tuple[set[str], dict[str, dict[str, Any]]]:
        """From one read of the log: the ids of the trials it holds a result of (failed trials are not done;
        with `retry_unstable`, neither are `unstable` ones not yet retried at half the timestep), and those
        unstable rows by id (empty without `retry_unstable`)."""
        rows = self.rows()
        retry = {row["trial_id"]: row for row in rows if retry_unstable and _needs_retry(row)}
        return {row["trial_id"] for row in rows if row.get("outcome") != FAILED} - retry.keys(), retry

    def append(self, row: dict[str, Any]) -> None:
        """Append one row as a single atomic line."""
        line = (json.dumps({k: _jsonable(v) for k, v in row.items()}, sort_keys=True) + "\n").encode()
        with self._lock:
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
            try:
                os.write(fd, line)
                os.fsync(fd)
            finally:
                os.close(fd)

    def frame(self) -> pd.DataFrame:
        """The log as a typed DataFrame (nested config flattened into columns)."""
        return typed(pd.json_normalize(self.rows(), sep="."))

    def extend(self, rows: Iterable[dict[str, Any]]) -> None:
        """Append several rows."""
        for row in rows:
            self.append(row)


def markdown(frame: pd.DataFrame, digits: int = 3) -> str:
    """Frame as a markdown table with numbers in %.{digits}g."""
    def fmt(v: Any) -> str:
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.{digits}g}"
        return str(v)

    head = "| " + " | ".join(frame.columns) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([head, rule, *body])
