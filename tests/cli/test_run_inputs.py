"""`entangle-bench run`: every bad input is exit 2 with a message naming it, before any trial runs."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import entangle_bench.cli.run as run_command
from entangle_bench.cli import main
from entangle_bench.suites import load_suite


class Ran(Exception):
    """Raised instead of running trials: carries the specs the CLI would have run."""

    def __init__(self, specs):
        super().__init__(len(specs))
        self.specs = specs


@pytest.fixture
def no_trials(monkeypatch):
    """Replace the runner as the CLI sees it: running any trial raises Ran(specs)."""

    def refuse(specs, *args, **kwargs):
        raise Ran(list(specs))

    monkeypatch.setattr(run_command, "run_trials", refuse)


def _unwritable(tmp_path: Path) -> Path:
    """A folder this process cannot create files in (root ignores permissions, so use /proc there)."""
    if os.geteuid() == 0:
        return Path("/proc/entangle-bench-test/out")
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o500)
    return folder


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["sphere", "--offsets", "0,abc"], "--offsets '0,abc': 'abc' is not an offset; expected comma-separated "
                                           "non-negative numbers in m"),
        (["sphere", "--offsets", "0,-0.01"], "'-0.01' is not an offset"),
        (["sphere", "--seed", "-1"], "--seed '-1': must be a non-negative integer"),
        (["sphere", "--workers", "0"], "--workers '0': must be a positive integer"),
        (["sphere", "--trials", "0"], "--trials '0': must be a positive integer"),
        (["sphere", "--trials", "two"], "--trials 'two': must be a positive integer"),
        (["sphere", "--preset", "quick"], "unknown preset 'quick'; known: accurate, balanced, fast"),
        (["default", "--set", "phases.hold_time_s=long"],
         "--set on suite default, condition conditions[0] (task top_drape/eight_branch_tree): "
         "phases.hold_time_s: expected"),
        (["offsets", "--set", "offset_m=0.01"], "use --offsets to change the offsets"),
        (["no_such_thing"], "unknown suite or task 'no_such_thing'; known: "),
    ],
)
def test_bad_arguments_exit_2_naming_the_problem(tmp_path, capsys, no_trials, argv, message):
    assert main(["run", *argv, "--out", str(tmp_path / "out"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("entangle-bench: error: ") and message in err, err


def test_out_pointing_at_a_file_is_refused(tmp_path, capsys, no_trials):
    target = tmp_path / "results.csv"
    target.write_text("x\n")
    assert main(["run", "sphere", "--out", str(target), "--no-progress"]) == 2
    assert f"--out {target}: is a file, not a folder" in capsys.readouterr().err
    assert target.read_text() == "x\n"


def test_an_output_folder_that_cannot_be_written_is_refused_before_any_trial(tmp_path, capsys, no_trials):
    folder = _unwritable(tmp_path)
    assert main(["run", "sphere", "--out", str(folder), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"output folder {folder} cannot be written" in err and "choose another with --out" in err


def test_set_and_preset_on_a_suite_apply_to_every_condition(tmp_path, no_trials):
    with pytest.raises(Ran) as ran:
        main(["run", "objects", "--trials", "1", "--preset", "fast", "--set", "phases.hold_time_s=1.5",
              "--out", str(tmp_path), "--no-progress"])
    specs = ran.value.specs
    assert len({s.config.object_name for s in specs}) > 3  # the objects suite: one condition per object
    assert all(s.preset == "fast" and s.config.phases.hold_time_s == 1.5 for s in specs)
    assert all(s.config.gripper.filament.n_segments == 12 for s in specs)  # fast preset's segments
    plain = load_suite("objects", trials=1)
    assert {s.trial_id for s in specs}.isdisjoint(s.trial_id for s in plain.specs)


def test_offsets_and_seed_on_a_suite_replace_the_files(tmp_path, no_trials):
    with pytest.raises(Ran) as ran:
        main(["run", "default", "--offsets", "0.005", "--seed", "7", "--out", str(tmp_path), "--no-progress"])
    specs = ran.value.specs
    assert {s.config.offset_m for s in specs} == {0.005}
    assert min(s.seed for s in specs) == 7
