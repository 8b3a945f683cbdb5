"""Runner: resumable sweeps, atomic logs, Wilson intervals, suite files, recordings."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from scipy import stats

from entangle_bench.cli import main
from entangle_bench.errors import FileFormatError, UnknownNameError
from entangle_bench.metrics.stats import success_table, wilson_interval
from entangle_bench.recording import read_recording
from entangle_bench.results import TrialLog
from entangle_bench.runner import SerialExecutor, run_trial, run_trials
from entangle_bench.suites import load_suite
from tests.suite.test_top_drape import SHORT, short_spec

TINY_SUITE = textwrap.dedent(
    """
    description = "tiny"
    trials = 3
    preset = "fast"
    [[conditions]]
    task = "sphere"
    set = { %s }
    [sweep]
    offset_m = [0.0, 0.01]
    """
) % ", ".join(f'"{s.split("=")[0]}" = {s.split("=")[1]}' for s in SHORT)


def test_wilson_interval_matches_the_closed_form_and_brackets_the_rate():
    low, high = wilson_interval(7, 10)
    # Wilson's score interval solves |p - 0.7| = z sqrt(p (1 - p) / n) for p: check both roots.
    z = stats.norm.ppf(0.975)
    for p in (low, high):
        assert abs(p - 0.7) == pytest.approx(z * np.sqrt(p * (1 - p) / 10), rel=1e-6)
    assert wilson_interval(0, 10)[0] == 0.0 and wilson_interval(10, 10)[1] == pytest.approx(1.0)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def test_success_table_ignores_unstable_trials():
    import pandas as pd

    rows = pd.DataFrame(
        {
            "condition": ["a"] * 4,
            "outcome": ["success", "failure", "unstable", "success"],
            "failure_mode": ["", "never_lifted", "", ""],
        }
    )
    table = success_table(rows, ["condition"]).iloc[0]
    assert table["trials"] == 4 and table["unstable"] == 1
    assert table["success_rate"] == pytest.approx(2 / 3)
    assert table["failure_modes"] == "never_lifted:1"


def test_log_drops_a_torn_line_and_duplicates(tmp_path):
    log = TrialLog(tmp_path / "t.jsonl")
    log.append({"trial_id": "a", "x": 1})
    log.append({"trial_id": "a", "x": 2})
    with open(log.path, "a") as handle:
        handle.write('{"trial_id": "b", "x"')  # a crash in the middle of a write
    log = TrialLog(log.path)
    assert [r["x"] for r in log.rows()] == [1]
    log.append({"trial_id": "b", "x": 3})
    assert log.done_ids() == {"a", "b"}


def test_suite_errors_name_file_key_and_problem(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('trials = 2\n[[conditions]]\ntask = "no_such_object"\n')
    with pytest.raises(FileFormatError, match=r"bad.toml.*conditions\[0\].task.*no_such_object"):
        load_suite(str(bad))
    bad.write_text('trials = 2\ncolour = 1\n[[conditions]]\ntask = "sphere"\n')
    with pytest.raises(FileFormatError, match="colour"):
        load_suite(str(bad))
    bad.write_text('[[conditions]]\ntask = "sphere"\nset = { "offset_m" = -1.0 }\n')
    with pytest.raises(FileFormatError, match="offset_m"):
        load_suite(str(bad))
    bad.write_text("trials = [")
    with pytest.raises(FileFormatError, match="TOML"):
        load_suite(str(bad))
    with pytest.raises(UnknownNameError, match="default"):
        load_suite("no_such_suite")


def test_shipped_suites_load():
    for name in ("default", "objects", "offsets", "spacing", "branch_length", "tree_mass"):
        header, specs = load_suite(name, trials=1)
        assert specs and len({s.trial_id for s in specs}) == len(specs), name


def test_killed_sweep_resumes_with_every_trial_exactly_once(tmp_path):
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY_SUITE)
    out = tmp_path / "out"
    log = out / "trials.jsonl"
    cmd = [sys.executable, "-m", "entangle_bench.cli", "run", str(suite), "--out", str(out),
           "--workers", "1", "--no-progress"]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.time() + 120
    while time.time() < deadline and not (log.exists() and log.read_text().count("\n") >= 2):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    partial = log.read_text().count("\n")
    assert 2 <= partial < 6, "the kill should land mid-sweep"
    assert subprocess.run(cmd, capture_output=True).returncode == 0
    ids = [json.loads(line)["trial_id"] for line in log.read_text().splitlines()]
    assert len(ids) == 6 and len(set(ids)) == 6
    assert (out / "summary.csv").exists() and (out / "success_vs_offset.png").exists()


def test_cli_run_task_in_process(tmp_path, capsys):
    code = main(["run", "sphere", "--trials", "1", "--workers", "1", "--preset", "fast", "--no-progress",
                 "--out", str(tmp_path)] + [a for s in SHORT for a in ("--set", s)])
    assert code == 0
    text = capsys.readouterr().out
    assert "success_rate" in text and "sphere" in text
    assert main(["run", "no_such_thing", "--out", str(tmp_path)]) == 2


def test_rerun_skips_finished_trials(tmp_path):
    specs = [short_spec("sphere", seed) for seed in (0, 1)]
    log = TrialLog(tmp_path / "trials.jsonl")
    assert len(run_trials(specs, log, SerialExecutor(), progress=False)) == 2
    assert run_trials(specs, log, SerialExecutor(), progress=False) == []


def test_recording_round_trip(tmp_path):
    spec = short_spec("sphere")
    row = run_trial(spec, record_dir=tmp_path)
    states = list(read_recording(tmp_path / f"{row['trial_id']}.mcap"))
    times = [s["time_s"] for s in states]
    assert times == sorted(times) and times[-1] == pytest.approx(row["sim_time_s"], abs=0.06)
    assert states[0]["centerlines_m"].shape[0] == spec.config.gripper.n_filaments
    assert {s["phase"] for s in states} >= {"approach", "hold"}
