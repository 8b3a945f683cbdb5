"""Hold-creep study: branches restored from one saved state, checked against each other and a resting object."""

import math

import numpy as np
import pytest

from entangle_bench.plots import plot_hold_creep
from entangle_bench.studies.hold_creep import hold_branches


def test_branches_start_from_the_same_state_and_a_resting_object_does_not_sink(short_spec, tmp_path):
    spec = short_spec("eight_branch_tree")  # fast and short: the tree is never lifted, it rests on the ground
    summary, series = hold_branches(spec.task, spec.config, spec.seed,
                                    {"first": {}, "again": {}, "noslip": {"noslip_iterations": 10}}, hold_s=0.2)
    first, again = (series[series["variant"] == v] for v in ("first", "again"))
    # Restoring the saved integration state replays the hold bit for bit.
    columns = ["t_s", "low_m", "tilt_deg"]
    assert np.array_equal(first[columns].to_numpy(), again[columns].to_numpy())
    assert first["t_s"].iloc[0] == 0.0 and first["t_s"].iloc[-1] == pytest.approx(0.2, abs=1e-9)
    # Every variant starts from the same grasp state.
    assert summary["start_low_m"].nunique() == 1
    # On the ground: the lowest point stays at the base (below the margin from the start) and does not sink.
    assert (summary["below_margin_at_s"] == 0.0).all()
    assert summary["start_low_m"].abs().max() < 2e-3
    assert (summary["sink_rate_m_s"].abs() < 1e-3).all()
    assert not math.isnan(summary.loc[summary["variant"] == "noslip", "sink_rate_m_s"].iloc[0])
    # The series draws as one line per variant.
    png = plot_hold_creep(series, tmp_path / "creep.png", spec.config.success_margin_m)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_branch_from_the_lift_reproduces_the_uninterrupted_trial(short_spec):
    from entangle_bench.runner import simulate
    from entangle_bench.studies.hold_creep import branch_outcomes

    spec = short_spec("eight_branch_tree")
    whole = simulate(spec.task, spec.config, spec.seed).row
    rows = branch_outcomes(spec.task, spec.config, spec.seed, {"configured": {}, "again": {}}, start_phase="lift")
    # Saved and restored state (MuJoCo's, the task's, the step count) continues the trial exactly.
    for _, row in rows.iterrows():
        assert (row["outcome"], row["failure_mode"]) == (whole["outcome"], whole["failure_mode"])
        for column in ("lift_clearance_m", "max_hold_tilt_deg", "peak_lift_force_w", "support.ground_w"):
            assert row[column] == whole[column], column


def test_a_continuation_after_an_unstable_one_starts_clean(short_spec):
    from entangle_bench.runner import simulate
    from entangle_bench.studies.hold_creep import branch_outcomes

    spec = short_spec("eight_branch_tree")
    whole = simulate(spec.task, spec.config, spec.seed).row
    # A 50 ms step blows the first continuation up; its MuJoCo warnings must not stop the next one.
    rows = branch_outcomes(spec.task, spec.config, spec.seed, {"blown": {"timestep": 0.05}, "configured": {}})
    blown, configured = rows.iloc[0], rows.iloc[1]
    assert blown["outcome"] == "unstable"
    assert configured["outcome"] == whole["outcome"]
    assert configured["lift_clearance_m"] == whole["lift_clearance_m"]


def test_a_variant_with_a_shorter_timestep_runs_to_the_episode_end(short_spec):
    from entangle_bench.studies.hold_creep import branch_outcomes
    from entangle_bench.suite import TASKS

    # dm_control's step limit counts control steps of the configured timestep: half the timestep would end the
    # episode halfway through, before the task decides (it crashed with "'NoneType' has no attribute 'status'").
    spec = short_spec("eight_branch_tree")
    rows = branch_outcomes(spec.task, spec.config, spec.seed,
                           {"half": {"timestep": spec.config.numerics.timestep_s / 2}}, start_phase="lift")
    row = rows.iloc[0]
    assert row["outcome"] in ("success", "failure")
    env = TASKS.get(spec.task).make_environment(spec.config, spec.seed)
    assert row["end_time_s"] == pytest.approx(env.task.schedule.boundaries()[-1][1], abs=1e-6)


def test_noslip_variants_are_refused_when_the_task_switches_noslip_per_phase(short_spec):
    from entangle_bench.errors import ParameterError
    from entangle_bench.studies.hold_creep import branch_outcomes

    spec = short_spec(extra=("numerics.noslip_iterations=10", "numerics.noslip_phases=hold"))
    config = spec.config
    # The task would overwrite the variant's noslip at every step: refused before anything simulates.
    with pytest.raises(ParameterError, match="noslip_phases"):
        hold_branches(spec.task, config, spec.seed, {"noslip": {"noslip_iterations": 5}}, hold_s=0.2)
    with pytest.raises(ParameterError, match="'noslip'.*noslip_phases"):
        branch_outcomes(spec.task, config, spec.seed, {"noslip": {"noslip_iterations": 5}})
    per_phase = short_spec(extra=("numerics.impratio=10", "numerics.impratio_phases=hold")).config
    with pytest.raises(ParameterError, match="'stiff'.*sets impratio.*impratio_phases"):
        branch_outcomes(spec.task, per_phase, spec.seed, {"stiff": {"impratio": 100}})


def test_a_config_variant_from_the_lift_equals_the_trial_run_with_that_config(short_spec):
    import dataclasses

    from entangle_bench.runner import simulate
    from entangle_bench.studies.hold_creep import branch_outcomes

    # impratio 10 from the lift (configured) or from the hold only (the variant): both are 1 before the lift,
    # so the branch point is the same state and the variant must replay the trial run with its config whole.
    spec = short_spec("eight_branch_tree", extra=("numerics.impratio=10", "numerics.impratio_phases=lift,hold"))
    from_hold = dataclasses.replace(
        spec.config, numerics=dataclasses.replace(spec.config.numerics, impratio_phases=("hold",))
    )
    whole = {name: simulate(spec.task, config, spec.seed).row
             for name, config in (("configured", spec.config), ("from hold", from_hold))}
    rows = branch_outcomes(spec.task, spec.config, spec.seed,
                           {"configured": {}, "from hold": {"numerics.impratio_phases": "hold"}}, start_phase="lift")
    columns = ("lift_clearance_m", "max_hold_tilt_deg", "peak_lift_force_w", "support.ground_w")
    for _, row in rows.iterrows():
        for column in columns:
            assert row[column] == whole[row["variant"]][column], (row["variant"], column)
    # The variant changed the physics: impratio 1 in the lift is not the configured trial.
    assert any(whole["configured"][c] != whole["from hold"][c] for c in columns)


def test_a_variant_sets_fields_valid_only_together_in_any_order(short_spec):
    # noslip_phases needs noslip_iterations > 0: set one after the other, the first would be refused.
    spec = short_spec("eight_branch_tree")
    summary, _ = hold_branches(spec.task, spec.config, spec.seed,
                               {"noslip from the hold": {"numerics.noslip_phases": "hold",
                                                         "numerics.noslip_iterations": "10"}}, hold_s=0.2)
    assert summary["variant"].tolist() == ["noslip from the hold"]


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"contact.friction": "1"}, "contact.friction, which the model is built from.*numerics.impratio_phases"),
        ({"numerics.impratio_phases": "grip"}, "impratio_phases.*'grip'.*lift"),
        ({"numerics.impratio": "0.5"}, "numerics.impratio"),
        ({"imp_ratio": 10}, "imp_ratio not an mjOption field.*impratio"),
    ],
)
def test_bad_variants_are_refused_before_anything_simulates(short_spec, changes, message):
    from entangle_bench.errors import ParameterError
    from entangle_bench.studies.hold_creep import branch_outcomes

    spec = short_spec()
    with pytest.raises(ParameterError, match=message):
        branch_outcomes(spec.task, spec.config, spec.seed, {"bad": changes})
