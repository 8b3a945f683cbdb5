"""Results files: typed CSV / Parquet / JSONL round trips, atomic writes with normal permissions, the log lock."""

import os
import stat

import numpy as np
import pandas as pd
import pytest

from entangle_bench.atomic import AtomicFile, atomic_save_npz, atomic_write_text
from entangle_bench.errors import FileFormatError
from entangle_bench.results import TrialLog, read_results, typed, write_trials

ROWS = [
    {"trial_id": "a", "seed": 0, "success": True, "outcome": "success", "failure_mode": "",
     "unstable_time_s": None, "lift_clearance_m": 0.031, "param.offset_m": 0.0,
     "config": {"object_name": "sphere", "phases": {"hold_time_s": 3.0}, "gripper": {"ring_counts": [8, 4]}}},
    {"trial_id": "b", "seed": 1, "success": False, "outcome": "unstable", "failure_mode": "",
     "unstable_time_s": 0.3125, "lift_clearance_m": 1e-17, "param.offset_m": 0.01,
     "config": {"object_name": "sphere", "phases": {"hold_time_s": 3.0}, "gripper": {"ring_counts": [8, 4]}},
     "first_unstable_reason": "nan_state"},
]
DTYPES = {"trial_id": "string", "seed": "int64", "success": "bool", "outcome": "string", "failure_mode": "string",
          "unstable_time_s": "float64", "lift_clearance_m": "float64", "param.offset_m": "float64",
          "config.object_name": "string", "config.phases.hold_time_s": "float64",
          "config.gripper.ring_counts": "string", "first_unstable_reason": "string"}


def _log(tmp_path) -> TrialLog:
    log = TrialLog(tmp_path / "trials.jsonl")
    log.extend(ROWS)
    return log


def test_every_format_reads_back_the_same_typed_frame(tmp_path):
    log = _log(tmp_path)
    frame = log.frame()
    assert {c: str(t) for c, t in frame.dtypes.items()} == DTYPES
    assert frame["config.gripper.ring_counts"].tolist() == ["[8, 4]", "[8, 4]"]
    assert frame["first_unstable_reason"].tolist() == ["", "nan_state"]
    csv_path, parquet_path = write_trials(frame, tmp_path)
    from_log = read_results(log.path)
    for path in (csv_path, parquet_path, tmp_path):
        pd.testing.assert_frame_equal(read_results(path), from_log)
    pd.testing.assert_frame_equal(from_log, frame)


def test_a_column_that_is_empty_in_every_row_keeps_a_useful_type(tmp_path):
    frame = typed(pd.DataFrame({"unstable_reason": ["", ""], "unstable_time_s": [None, None], "x": [1, 2]}))
    write_trials(frame, tmp_path)
    for path in (tmp_path / "trials.csv", tmp_path / "trials.parquet"):
        back = read_results(path)
        assert str(back["unstable_reason"].dtype) == "string" and back["unstable_reason"].tolist() == ["", ""]
        assert back["unstable_time_s"].dtype == np.float64 and back["unstable_time_s"].isna().all()


def test_missing_integers_and_bools_stay_typed(tmp_path):
    frame = typed(pd.DataFrame({"n": [1, None, 3], "ok": [True, None, False]}, dtype=object))
    assert str(frame["n"].dtype) == "Int64" and str(frame["ok"].dtype) == "boolean"
    write_trials(frame, tmp_path)
    pd.testing.assert_frame_equal(read_results(tmp_path / "trials.parquet"), frame)
    pd.testing.assert_frame_equal(read_results(tmp_path / "trials.csv"), frame)


def test_unreadable_results_name_the_file_and_what_is_allowed(tmp_path):
    with pytest.raises(FileFormatError, match="no trials.parquet, trials.csv or trials.jsonl"):
        read_results(tmp_path)
    (tmp_path / "x.txt").write_text("hello")
    with pytest.raises(FileFormatError, match=r"x.txt.*\.parquet, \.csv or \.jsonl"):
        read_results(tmp_path / "x.txt")
    (tmp_path / "trials.parquet").write_text("not parquet")
    with pytest.raises(FileFormatError, match="trials.parquet"):
        read_results(tmp_path / "trials.parquet")


def test_written_files_have_normal_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        paths = [*write_trials(_log(tmp_path).frame(), tmp_path), atomic_write_text(tmp_path / "a.txt", "x"),
                 atomic_save_npz(tmp_path / "a.npz", x=np.zeros(2)), tmp_path / "trials.jsonl"]
    finally:
        os.umask(old)
    for path in paths:
        assert stat.S_IMODE(path.stat().st_mode) == 0o644, path
    assert not [p.name for p in tmp_path.iterdir() if ".tmp" in p.name]


def test_failed_atomic_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "summary.csv"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt), AtomicFile(target) as out:
        out.tmp.write_text("half")
        raise KeyboardInterrupt
    assert target.read_text() == "old" and list(tmp_path.iterdir()) == [target]


def test_log_lock_is_held_while_appending(tmp_path, monkeypatch):
    log = TrialLog(tmp_path / "trials.jsonl")
    held = []
    real_write = os.write

    def spying_write(fd, data):
        held.append(log._lock.is_locked)
        return real_write(fd, data)

    monkeypatch.setattr(os, "write", spying_write)
    log.append({"trial_id": "x"})
    assert held == [True] and not log._lock.is_locked
