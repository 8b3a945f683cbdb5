"""Runner: resumable sweeps, atomic logs, Wilson intervals, suite files, observers, recordings."""

import json
import textwrap

import numpy as np
import pytest
from scipy import stats

from entangle_bench.cli import main
from entangle_bench.config import to_flat_dict
from entangle_bench.errors import FileFormatError, UnknownNameError
from entangle_bench.executors import SerialExecutor
from entangle_bench.metrics.stats import success_table, wilson_interval
from entangle_bench.recording import read_recording
from entangle_bench.results import TrialLog
from entangle_bench.runner import ID_NEUTRAL_FIELDS, Watch, run_trial, run_trials, simulate
from entangle_bench.suite import SHORT_SEQUENCE
from entangle_bench.suites import SUITES, load_suite, task_suite

SHORT = SHORT_SEQUENCE

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


def test_suite_set_applies_to_every_condition_before_its_own(tmp_path):
    path = tmp_path / "shared.toml"
    path.write_text('[set]\n"contact.friction" = 1.5\n"phases.hold_time_s" = 3.0\n'
                    '[[conditions]]\ntask = "sphere"\n'
                    '[[conditions]]\ntask = "cylinder_38"\nset = { "contact.friction" = 0.5 }\n')
    sphere, cylinder = (s.config for s in load_suite(str(path)).specs)
    assert (sphere.contact.friction, sphere.phases.hold_time_s) == (1.5, 3.0)
    assert (cylinder.contact.friction, cylinder.phases.hold_time_s) == (0.5, 3.0)
    path.write_text('[set]\n"contact.frictio" = 1.5\n[[conditions]]\ntask = "sphere"\n')
    with pytest.raises(FileFormatError, match=r"shared.toml.*'set.contact.frictio'.*condition conditions\[0\]"):
        load_suite(str(path))
    path.write_text('set = 3\n[[conditions]]\ntask = "sphere"\n')
    with pytest.raises(FileFormatError, match=r"'set'.*must be a table"):
        load_suite(str(path))


def test_shipped_suites_load():
    assert SUITES.names() == [
        "branch_length", "calibration", "default", "grasp_probe", "objects", "offsets", "pullout", "spacing",
        "tree_mass",
    ]
    for name in SUITES.names():
        suite = load_suite(name, trials=1)
        assert suite.specs and len({s.trial_id for s in suite.specs}) == len(suite.specs), name
        assert all(s.preset == suite.preset for s in suite.specs)


def test_suite_without_preset_uses_the_default_preset(tmp_path):
    from entangle_bench.presets import DEFAULT_PRESET

    path = tmp_path / "plain.toml"
    path.write_text('[[conditions]]\ntask = "sphere"\n')
    suite = load_suite(str(path))
    assert suite.preset == DEFAULT_PRESET and suite.specs[0].preset == DEFAULT_PRESET
    assert suite.specs[0].trial_id == task_suite("sphere").specs[0].trial_id  # one way to make a spec


class KilledAfter:
    """Executor that runs `n` trials, then stops the sweep as a kill between two trials would."""

    def __init__(self, n):
        self.n = n

    def map_unordered(self, fn, items):
        for item in items[: self.n]:
            yield item, fn(item)
        raise KeyboardInterrupt


def test_killed_sweep_resumes_with_every_trial_exactly_once(tmp_path):
    """Two trials logged, a third torn mid-write by the kill; the rerun adds the other four, once each."""
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY_SUITE)
    out = tmp_path / "out"
    log = TrialLog(out / "trials.jsonl")
    specs = list(load_suite(str(suite)).specs)
    with pytest.raises(KeyboardInterrupt):
        run_trials(specs, log, KilledAfter(2), progress=False)
    first = log.path.read_text().splitlines()
    assert len(first) == 2
    with open(log.path, "a") as handle:
        handle.write(json.dumps({"trial_id": specs[5].trial_id, "outcome": "fail"})[:25])  # the torn write
    argv = ["run", str(suite), "--out", str(out), "--workers", "1", "--no-progress"]
    assert main(argv) == 0
    lines = log.path.read_text().splitlines()
    ids = [json.loads(line)["trial_id"] for line in lines]
    assert sorted(ids) == sorted(s.trial_id for s in specs)
    assert lines[:2] == first  # finished trials were not rerun
    assert (out / "summary.csv").exists() and (out / "success_vs_offset.png").exists()


def test_cli_run_task_in_process(tmp_path, capsys):
    code = main(["run", "sphere", "--trials", "1", "--workers", "1", "--preset", "fast", "--no-progress",
                 "--out", str(tmp_path)] + [a for s in SHORT for a in ("--set", s)])
    assert code == 0
    text = capsys.readouterr().out
    assert "success_rate" in text and "sphere" in text
    assert main(["run", "no_such_thing", "--out", str(tmp_path)]) == 2


def test_a_run_that_adds_seeds_summarizes_every_seed_of_its_conditions_and_only_those(tmp_path):
    """Seed 0, then seed 1 into the same folder: the summary counts both; a run of another configuration into
    that folder counts only its own trial."""
    import pandas as pd

    base = ["run", "sphere", "--trials", "1", "--workers", "1", "--preset", "fast", "--no-progress",
            "--out", str(tmp_path)] + [a for s in SHORT for a in ("--set", s)]
    assert main(base) == 0
    assert main(base + ["--seed", "1"]) == 0
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert summary["trials"].tolist() == [2]
    assert sorted(pd.read_csv(tmp_path / "trials.csv")["seed"]) == [0, 1]
    assert main(base + ["--set", "phases.hold_time_s=0.2"]) == 0
    assert pd.read_csv(tmp_path / "summary.csv")["trials"].tolist() == [1]
    assert len(TrialLog(tmp_path / "trials.jsonl").rows()) == 3
    # `report` rewrites the folder from the whole log: one condition label, or one group per hold time.
    assert main(["report", str(tmp_path)]) == 0
    assert pd.read_csv(tmp_path / "summary.csv")["trials"].tolist() == [3]
    assert len(pd.read_csv(tmp_path / "trials.csv")) == 3
    assert main(["report", str(tmp_path), "--by", "config.phases.hold_time_s"]) == 0
    summary = pd.read_csv(tmp_path / "summary.csv")
    assert dict(zip(summary["condition"], summary["trials"]))[0.2] == 1 and sorted(summary["trials"]) == [1, 2]
    assert main(["report", str(tmp_path), "--by", "config.no_such_field"]) == 2
    assert main(["report", str(tmp_path / "missing")]) == 2


def test_fields_at_their_neutral_value_stay_out_of_the_trial_id():
    """A field added after results were logged keeps the old ids at its neutral value (the pinned rows check
    those ids) and changes the id at any other value; every neutral field is a real field at its default."""
    for task in ("eight_branch_tree", "pullout_cylinder_51"):
        flat = to_flat_dict(task_suite(task).specs[0].config)
        for key, neutral in ID_NEUTRAL_FIELDS.items():
            assert flat[key] == neutral
    default, neutral, changed = (task_suite("eight_branch_tree", overrides=o).specs[0].trial_id
                                 for o in ([], ["contact.filament_friction=none"], ["contact.filament_friction=3"]))
    assert default == neutral != changed


def test_rerun_skips_finished_trials(tmp_path, short_spec):
    specs = [short_spec("sphere", seed) for seed in (0, 1)]
    log = TrialLog(tmp_path / "trials.jsonl")
    assert len(run_trials(specs, log, SerialExecutor(), progress=False)) == 2
    assert run_trials(specs, log, SerialExecutor(), progress=False) == []


def test_recording_round_trip(tmp_path, short_spec):
    spec = short_spec("sphere")
    row = run_trial(spec, folder=tmp_path, watch=Watch(record=True))
    states = list(read_recording(tmp_path / "recordings" / f"{row['trial_id']}.mcap"))
    times = [s["time_s"] for s in states]
    assert times == sorted(times) and times[-1] == pytest.approx(row["sim_time_s"], abs=0.06)
    assert states[0]["centerlines_m"].shape[0] == spec.config.gripper.n_filaments
    assert {s["phase"] for s in states} >= {"approach", "hold"}


class Counter:
    """Test observer counting the calls the runner makes."""

    def __init__(self):
        self.starts, self.steps, self.finished = 0, 0, []

    def start(self, env):
        self.starts += 1
        assert self.steps == 0 and env.physics.time() == 0.0

    def step(self, env):
        self.steps += 1

    def finish(self, row, complete):
        self.finished.append((row["outcome"], complete))


def test_observers_see_every_control_step_and_the_final_row(short_spec):
    spec = short_spec("sphere")
    counter = Counter()
    result = simulate(spec.task, spec.config, spec.seed, observers=[counter])
    steps = round(result.row["sim_time_s"] / spec.config.control_timestep_s)
    assert counter.starts == 1 and counter.steps == steps
    assert counter.finished == [(result.row["outcome"], True)]


class DeepestContact:
    """Observer: (time s, deepest contact m) at the end of each control step with contacts."""

    def __init__(self):
        self.depths = []

    def start(self, env):
        pass

    def step(self, env):
        data = env.physics.data.ptr
        if data.ncon:
            self.depths.append((env.physics.time(), -float(data.contact.dist[: data.ncon].min())))

    def finish(self, row, complete):
        pass


def test_row_records_the_deepest_contact_the_watchdog_saw(short_spec):
    """The row's max_penetration_m is the deepest contact over the control steps, measured here independently."""
    spec = short_spec("eight_branch_tree")
    probe = DeepestContact()
    result = simulate(spec.task, spec.config, spec.seed, observers=[probe])
    grace = result.env.task.watchdog_limits().grace_time_s
    deepest = max(depth for t, depth in probe.depths if t >= grace)
    assert deepest > 1e-5  # the filaments touch the tree, so the check is not vacuous
    assert result.row["max_penetration_m"] == pytest.approx(deepest, rel=1e-12)


def test_unstable_trial_calls_finish_with_the_unstable_row(short_spec, nan_at):
    spec = short_spec("sphere")
    counter = Counter()
    row = run_trial(spec, observers=[nan_at(0.2), counter])
    assert row["outcome"] == "unstable"
    assert counter.finished == [("unstable", True)]
    assert counter.steps == round(row["unstable_time_s"] / spec.config.control_timestep_s) - 1


def test_task_series_are_logged_every_control_step_and_saved(tmp_path, monkeypatch):
    from entangle_bench.suite.probe import Probe, ProbeConfig

    monkeypatch.setattr(Probe, "series_point", lambda self, physics: {"pressure_pa": self.pressure_pa})
    config = ProbeConfig(duration_s=0.2, ramp_time_s=0.1)
    result = simulate("probe/curl_in_air", config, 0, state_dir=tmp_path)
    series = result.series
    assert len(series["time_s"]) == 20
    np.testing.assert_allclose(series["time_s"], 0.01 * np.arange(1, 21), atol=1e-9)
    pressure = config.gripper.pressure_pa
    # The pressure of each step is the one commanded at its start: t / ramp, full from 0.1 s on.
    np.testing.assert_allclose(series["pressure_pa"], pressure * np.minimum(1.0, 0.01 * np.arange(20) / 0.1))
    saved = np.load(next(tmp_path.glob("*_series.npz")))
    assert set(saved.files) == {"time_s", "pressure_pa"}
    np.testing.assert_array_equal(saved["pressure_pa"], series["pressure_pa"])


def test_a_task_must_decide_and_may_decide_only_once(monkeypatch):
    from entangle_bench.errors import OutcomeError
    from entangle_bench.suite import Outcome
    from entangle_bench.suite.probe import Probe, ProbeConfig

    config = ProbeConfig(duration_s=0.05)
    env = simulate("probe/curl_in_air", config, 0).env
    with pytest.raises(OutcomeError, match="twice"):
        env.task.decide(Outcome("failure", "again"))
    monkeypatch.setattr(Probe, "after_step", lambda self, physics: None)
    with pytest.raises(OutcomeError, match="without deciding"):
        simulate("probe/curl_in_air", config, 0)
