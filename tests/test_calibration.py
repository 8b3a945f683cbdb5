"""Calibration verdicts: targets (a)–(d) judged on synthetic rows whose answers follow from the definitions."""

import pandas as pd
import pytest

from entangle_bench import calibration
from entangle_bench.cli import build_parser
from entangle_bench.suite import TASKS, resolve_config
from entangle_bench.suites import load_suite

TREE, SPHERE, CYLINDER = calibration.TREE_TASK, *calibration.CONTROL_TASKS


def rows(*conditions):
    """Rows of (task, offset m, successes, failures, unstable) conditions."""
    out = []
    for task, offset, k, failures, unstable in conditions:
        out += [{"task": task, "config.offset_m": offset, "outcome": outcome}
                for outcome in ["success"] * k + ["failure"] * failures + ["unstable"] * unstable]
    return pd.DataFrame(out)


def pullout(sphere, tree, cylinder):
    return pd.DataFrame({"config.object_name": ["sphere", "eight_branch_tree", "cylinder_51"],
                         "toughness_median_j": [sphere, tree, cylinder]})


def test_targets_are_met_missed_or_open_by_trial_count_and_intervals():
    off = calibration.tree_offset_m()
    met = calibration.target_table(
        rows((TREE, 0.0, 17, 3, 2), (TREE, off, 15, 5, 0), (SPHERE, 0.0, 2, 18, 0), (CYLINDER, 0.0, 5, 15, 1)),
        pullout(0.012, 0.30, 1.5))
    assert met["status"].tolist() == ["met"] * 5
    assert met["measured"][0] == "17/20 = 85 % [64, 95] (+2 unstable)"  # unstable trials never enter the rate
    assert "ratios 1.2, 0.79, 1.9" in met["measured"][4]
    # 20 trials each: 80 % missed by one success; the offset 25 points off; the sphere as good as the tree.
    missed = calibration.target_table(
        rows((TREE, 0.0, 15, 5, 0), (TREE, off, 10, 10, 0), (SPHERE, 0.0, 15, 5, 0), (CYLINDER, 0.0, 0, 20, 0)),
        pullout(0.5, 0.30, 1.5))
    assert missed["status"].tolist() == ["missed", "missed", "missed", "met", "missed"]  # toughness out of order
    # Too few trials: open, unless the Wilson intervals already exclude the target.
    few = calibration.target_table(rows((TREE, 0.0, 3, 3, 0), (TREE, off, 0, 5, 0), (SPHERE, 0.0, 0, 3, 0)))
    assert few["status"].tolist() == ["open"] * 5
    excluded = calibration.target_table(rows((TREE, 0.0, 0, 8, 0), (TREE, off, 0, 0, 0)), pullout(0.01, 0.38, 0.2))
    assert excluded["status"].tolist() == ["missed", "open", "open", "open", "missed"]
    # An object without a toughness (its pull-outs all unstable) leaves (d) open and is named.
    partial = calibration.target_table(rows((TREE, 0.0, 0, 8, 0)), pullout(0.0, float("nan"), -0.0028))
    assert partial["status"].tolist()[4] == "open"
    assert partial["measured"][4] == "sphere 0 mJ, cylinder_51 -2.8 mJ, no toughness: eight_branch_tree"
    # The mid-air pull-out is judged in its own row; without one there is no such row.
    both = calibration.target_table(rows((TREE, 0.0, 17, 3, 0)), pullout(0.012, 0.30, 1.5), pullout(0.0, 0.09, -0.003))
    assert both["target"].tolist()[4:] == ["(d) pull-out toughness", "(d) pull-out toughness, object in mid-air"]
    assert both["status"].tolist()[4:] == ["met", "missed"]
    assert both["measured"][5] == "sphere 0 mJ, eight_branch_tree 90 mJ, cylinder_51 -3 mJ (ratios 0, 0.24, -0.0039)"
    assert len(missed) == 5


def test_offset_condition_is_the_calibration_suites_and_parameters_flag_their_range():
    suite = load_suite(calibration.CALIBRATION_SUITE, trials=1)
    offsets = sorted({spec.config.offset_m for spec in suite.specs if spec.task == TREE})
    assert offsets == [0.0, pytest.approx(calibration.tree_offset_m(), abs=5e-4)]
    # The overrides give the suite's own tree config (lists and booleans included), so the tables and the
    # pull-out describe the trials that ran.
    tree = next(spec for spec in suite.specs if spec.task == TREE and spec.config.offset_m == 0.0)
    assert resolve_config("eight_branch_tree", suite.preset, calibration.candidate_overrides()) == tree.config
    table = calibration.candidate_parameters(calibration.candidate_overrides()).set_index("parameter")
    assert table.loc["gripper.filament.outer_radius_m", "inside_physical_range"] == "no"  # aspect ratio 150 < 200
    assert table.loc["gripper.filament.youngs_modulus_pa", "inside_physical_range"] == "yes"
    assert table.loc["gripper.filament.youngs_modulus_pa", "value"] != table.loc[
        "gripper.filament.youngs_modulus_pa", "default"]
    # The pull-out keeps the gripper and contact settings but has no lift to override.
    pull = calibration.pullout_overrides(calibration.candidate_overrides())
    assert any(o.startswith("contact.friction=") for o in pull)
    assert not any(o.startswith("phases.lift_height_m=") for o in pull)
    # Noslip over the top-drape's carrying phases becomes noslip over the pull-out's (its own phase names).
    pull = calibration.pullout_overrides(["numerics.noslip_iterations=10", "numerics.noslip_phases=settle,lift,hold"])
    assert pull[1] == "numerics.noslip_phases=settle,clamp,pull"
    impratio = calibration.pullout_overrides(["numerics.impratio_phases=lift,hold"])
    assert impratio == ["numerics.impratio_phases=clamp,pull"]
    config = resolve_config("pullout_eight_branch_tree", None, pull)
    TASKS.get("pullout_eight_branch_tree").make_environment(config, 0)  # the phases are the pull-out's own


def test_a_calibration_run_retries_unstable_trials_and_pulls_out_with_the_candidates_settings(tmp_path):
    suite_run, pull_run, midair_run = (build_parser().parse_args(command) for command in calibration.run_commands(
        tmp_path, 20, 5, 2, ["contact.friction=1.5", "phases.lift_height_m=0.06"]))
    assert (suite_run.target, pull_run.target) == (calibration.CALIBRATION_SUITE, calibration.PULLOUT_SUITE)
    assert (suite_run.trials, pull_run.trials, suite_run.workers) == ("20", "5", "2")
    assert (suite_run.out, pull_run.out) == (tmp_path, tmp_path / "pullout")
    # Both retry: dropping the trials that break would bias the rates and the toughness low.
    assert suite_run.retry_unstable and pull_run.retry_unstable
    assert suite_run.overrides == ["contact.friction=1.5", "phases.lift_height_m=0.06"]
    # The pull-out gets the calibration suite's gripper with the candidate's override last (it wins), no lift.
    assert pull_run.overrides == calibration.pullout_overrides([*calibration.candidate_overrides(),
                                                                "contact.friction=1.5"])
    assert pull_run.overrides[-1] == "contact.friction=1.5"
    assert resolve_config("pullout_eight_branch_tree", None, pull_run.overrides).contact.friction == 1.5
    # The mid-air pull-out is the same run with the object welded 0.3 m up and no post geom.
    assert (midair_run.target, midair_run.out, midair_run.retry_unstable) == (
        calibration.PULLOUT_SUITE, tmp_path / "pullout_midair", True)
    assert midair_run.overrides == [*pull_run.overrides, *calibration.MIDAIR_MOUNT]
    mounted = resolve_config("pullout_cylinder_51", None, midair_run.overrides)
    assert (mounted.pull.post_height_m, mounted.pull.post_radius_m) == (0.3, 0.0)
