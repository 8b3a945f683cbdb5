"""Catch screen: it stops where the runner's `actuated` snapshot is taken, and its table counts what it says."""

import numpy as np
import pandas as pd
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.runner import simulate
from entangle_bench.studies.catch import catch_at_lift, catch_outcome_table, screen


def test_screen_state_is_the_trials_actuated_snapshot(short_spec, tmp_path):
    spec = short_spec("eight_branch_tree")
    whole = simulate(spec.task, spec.config, spec.seed, state_dir=tmp_path / "run", state_id="t").row
    caught = catch_at_lift(spec.task, spec.config, spec.seed, tmp_path / "screen" / "t_actuated.npz")
    assert caught["unstable"] == ""
    with np.load(tmp_path / "run" / "t_actuated.npz") as ran, np.load(tmp_path / "screen" / "t_actuated.npz") as saved:
        assert sorted(saved.files) == sorted(ran.files) and "curves" in saved.files
        for name in ran.files:  # the saved arrays are the runner's snapshot, bit for bit
            np.testing.assert_array_equal(saved[name], ran[name])
    actuated = {k: v for k, v in whole.items() if k.startswith("actuated.")}
    assert actuated and {k: caught[k] for k in actuated} == actuated  # bit for bit, every snapshot metric
    assert caught["sim_time_s"] < whole["sim_time_s"]
    touching = caught["filaments_touching_object"]
    assert 0 <= touching <= min(spec.config.gripper.n_filaments, caught["actuated.contacts.filament-object"])
    assert (caught["object_normal_force_n"] > 0) == (touching > 0)


def test_screen_fails_on_a_bad_variant_before_running(short_spec):
    spec = short_spec("eight_branch_tree")
    with pytest.raises(ParameterError, match="drape_depth_m"):
        screen(spec.task, "fast", {"ok": [], "bad": ["phases.drape_depth_m=-1"]}, [0])


def test_catch_outcome_table_bins_scored_trials():
    rows = pd.DataFrame({
        "outcome": ["success", "failure", "failure", "success", "unstable", "success"],
        "actuated.contacts.filament-object": [5, 10, 25, 45, 50, 40],
    })
    table = catch_outcome_table(rows, edges=(0, 22, 40))
    assert table["contacts"].tolist() == ["0–21", "22–39", "≥ 40"]
    assert table["trials"].tolist() == [2, 1, 2]  # the unstable trial is not scored
    assert table["successes"].tolist() == [1, 0, 2]
    assert table["rate"].tolist() == [0.5, 0.0, 1.0]
    assert np.all(table["ci95_low"] <= table["rate"]) and np.all(table["rate"] <= table["ci95_high"])
