"""Catch screen: it stops where the runner's `actuated` snapshot is taken, and its table counts what it says."""

import numpy as np
import pandas as pd
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.runner import simulate
from entangle_bench.studies.catch import catch_at_lift, catch_outcome_table, parse_variant, screen, screen_table
from entangle_bench.suite import resolve_config


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


def test_screen_table_pairs_seeds_and_survives_a_variant_that_never_stays_stable():
    ok = {"actuated.contacts.filament-object": 0, "actuated.contacts.filament-self": 0,
          "filaments_touching_object": 0, "object_normal_force_n": 0.0}
    rows = pd.DataFrame([
        {"variant": "base", "seed": 0, "unstable": "", "wall_s": 10.0, **ok, "actuated.contacts.filament-object": 40},
        {"variant": "base", "seed": 1, "unstable": "", "wall_s": 20.0, **ok, "actuated.contacts.filament-object": 60},
        {"variant": "wide", "seed": 0, "unstable": "", "wall_s": 30.0, **ok, "actuated.contacts.filament-object": 50},
        {"variant": "wide", "seed": 1, "unstable": "speed 30 m/s", "wall_s": 5.0},
        {"variant": "soft", "seed": 0, "unstable": "invalid state", "wall_s": 4.0},
    ])
    table = screen_table(rows).set_index("variant")
    assert table.index.tolist() == ["base", "wide", "soft"]  # the baseline first, in the order run
    assert table.loc["base", "contacts_mean"] == 50 and table.loc["base", "paired_contacts_diff"] == 0
    assert (table.loc["wide", "stable"], table.loc["wide", "run"]) == (1, 2)
    assert table.loc["wide", "paired_contacts_diff"] == 10 and table.loc["wide", "paired_seeds"] == 1  # seed 0 only
    assert table.loc["wide", "wall_mean_s"] == 17.5  # unstable runs cost time too
    assert table.loc["soft", "stable"] == 0 and np.isnan(table.loc["soft", "contacts_mean"])
    only_unstable = screen_table(rows[rows["variant"] == "soft"])  # the case that raised KeyError before
    assert only_unstable["stable"].tolist() == [0] and only_unstable["paired_seeds"].tolist() == [0]


def test_parse_variant_keeps_a_tuple_values_commas():
    name, overrides = parse_variant("wide:gripper.ring_diameters_m=0.056,0.025,phases.drape_depth_m=0.3")
    assert name == "wide"
    assert overrides == ["gripper.ring_diameters_m=0.056,0.025", "phases.drape_depth_m=0.3"]
    config = resolve_config("eight_branch_tree", "balanced", overrides)
    assert config.gripper.ring_diameters_m == (0.056, 0.025) and config.phases.drape_depth_m == 0.3
    with pytest.raises(ParameterError, match="expected NAME:a.b=value"):
        parse_variant("gripper.ring_diameters_m=0.056")
