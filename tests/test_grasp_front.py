"""Numerical variants judged against a fine run on grasp outcomes: verdicts follow from the Wilson intervals."""

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.metrics import stats
from entangle_bench.metrics.stats import wilson_interval
from entangle_bench.results import write_trials
from entangle_bench.studies import grasp_front

TREE = "top_drape/eight_branch_tree"
ROOT = Path(__file__).resolve().parents[1]


def trials(successes, failures, unstable=0, timestep_s=2.5e-4, wall_per_sim_s=50.0, friction=2.0, segments=40):
    """Rows of one condition: seeds 0, 1, ... with these outcomes, in this order."""
    outcomes = ["success"] * successes + ["failure"] * failures + ["unstable"] * unstable
    return pd.DataFrame({
        "task": TREE, "config.offset_m": 0.0, "seed": range(len(outcomes)), "outcome": outcomes,
        "config.numerics.timestep_s": timestep_s, "config.numerics.integrator": "euler",
        "config.gripper.filament.n_segments": segments, "config.contact.friction": friction,
        "config.object.branch_count": 8, "wall_time_s": wall_per_sim_s * 11.4, "sim_time_s": 11.4,
    })


def test_verdicts_follow_the_intervals_and_the_trial_count():
    fine = trials(17, 3, timestep_s=1.25e-4, wall_per_sim_s=100.0)
    variants = {
        "fine": fine,
        "same": trials(16, 5, 1, wall_per_sim_s=50.0),  # 16/21: overlaps 17/20, both >= 20 scored
        "cheaper": trials(15, 5, wall_per_sim_s=20.0),  # 15/20 overlaps too, and costs less
        "broken": trials(0, 4, 1, timestep_s=5e-4, wall_per_sim_s=10.0),  # [0, 49] % against [64, 95] %
        "few": trials(2, 2, timestep_s=5e-4, wall_per_sim_s=5.0),  # overlaps, but 4 scored: open
    }
    front = grasp_front.front_table(variants, "fine").set_index("variant")
    assert front["verdict"].to_dict() == {"fine": "fine run", "same": "agrees", "cheaper": "agrees",
                                          "broken": "differs", "few": "open"}
    low, high = wilson_interval(0, 4)
    assert front.loc["broken", ["ci95_low", "ci95_high"]].tolist() == pytest.approx([low, high])
    assert high < wilson_interval(17, 20)[0]  # the reason `broken` differs
    assert front.loc["same", ["scored", "unstable", "successes"]].tolist() == [21, 1, 16]
    # Seeds 0-15 succeed in both, 16 fails in `same` and succeeds in `fine`, 17-19 fail in both: 19 of 20 alike.
    assert front.loc["same", ["paired_seeds", "paired_same_outcome"]].tolist() == [20, 19]
    assert front.loc["cheaper", "cost_ratio"] == pytest.approx(0.2)
    assert front.loc["fine", "timestep_ms"] == pytest.approx(0.125)
    assert grasp_front.cheapest_agreeing(front.reset_index()) == "cheaper"
    # Without an agreeing variant the fine run is the default; with too few fine trials there is no verdict yet.
    alone = grasp_front.front_table({"fine": fine, "broken": variants["broken"]}, "fine")
    assert grasp_front.cheapest_agreeing(alone) == "fine"
    short = grasp_front.front_table({"fine": trials(8, 2), "same": trials(16, 4)}, "fine")
    assert short.set_index("variant").loc["same", "verdict"] == "open"
    assert grasp_front.cheapest_agreeing(short) is None


def test_seeds_both_scored_are_pairs_and_a_one_sided_change_on_them_differs():
    """10/20 and 17/20 overlap ([30, 70] % and [64, 95] %), but on the same seeds the variant loses 7 successes
    and gains none: exact McNemar p = 2 / 2^7 = 0.0156 < 0.05. Losing 2 and gaining 0 gives p = 0.5."""
    fine = trials(17, 3, timestep_s=1.25e-4)
    front = grasp_front.front_table({"fine": fine, "lossy": trials(10, 10), "close": trials(15, 5)}, "fine")
    front = front.set_index("variant")
    assert wilson_interval(10, 20)[1] > wilson_interval(17, 20)[0]  # the intervals alone would not tell
    assert front.loc["lossy", ["paired_fine_only", "paired_variant_only"]].tolist() == [7, 0]
    assert front.loc["lossy", "paired_p"] == pytest.approx(2 / 2**7)
    assert front.loc["close", "paired_p"] == pytest.approx(0.5)
    assert front["verdict"].to_dict() == {"fine": "fine run", "lossy": "differs", "close": "agrees"}
    assert stats.paired_exact_p(0, 0) == 1.0 and stats.paired_exact_p(3, 3) == pytest.approx(1.0)
    with pytest.raises(ParameterError, match="discordant pair counts must be >= 0"):
        stats.paired_exact_p(-1, 2)


def test_a_variant_may_change_only_the_numerics():
    fine = trials(17, 3, timestep_s=1.25e-4, segments=60)
    # The same value read back as text ("8.0" from a CSV) is the same setting.
    as_text = trials(15, 5).assign(**{"config.object.branch_count": "8.0"})
    grasp_front.front_table({"fine": fine, "coarse": as_text}, "fine")
    # the stretch joint's armature changes no equilibrium: a numerical setting like the step
    armature = "config.gripper.filament.stretch_armature_ratio"
    grasp_front.front_table({"fine": fine.assign(**{armature: 0.0}),
                             "modal": trials(15, 5).assign(**{armature: 0.405})}, "fine")
    with pytest.raises(ParameterError, match=r"'grippier'.*config\.contact\.friction.*\['3\.0'\] against \['2\.0'\]"):
        grasp_front.front_table({"fine": fine, "grippier": trials(15, 5, friction=3.0)}, "fine")
    with pytest.raises(ParameterError, match="fine run 'reference' is not among the variants"):
        grasp_front.front_table({"fine": fine}, "reference")


def pulls(object_name, toughness_j):
    return pd.DataFrame({
        "config.object_name": object_name, "config.gripper.pressure_pa": 172e3, "outcome": "success",
        "pull_result": "released", "peak_force_n": 1.0, "toughness_j": toughness_j, "config.contact.friction": 2.0,
    })


def test_toughness_verdicts_and_the_default_that_agrees_on_both():
    fine = pulls("eight_branch_tree", [0.06, 0.07, 0.08, 0.09, 0.10])
    pullouts = {
        "fine": fine,
        "cheaper": pulls("eight_branch_tree", [0.065, 0.075, 0.085, 0.095, 0.105]),
        "weak": pulls("eight_branch_tree", [0.001, 0.002, 0.003, 0.004, 0.005]),
        "short": pulls("eight_branch_tree", [0.07, 0.08]),
    }
    table = grasp_front.toughness_front(pullouts, "fine").set_index("variant")
    assert table["verdict"].to_dict() == {"fine": "fine run", "cheaper": "agrees", "weak": "differs", "short": "open"}
    assert table.loc["fine", "toughness_median_j"] == pytest.approx(0.08)
    front = grasp_front.front_table({"fine": trials(17, 3, wall_per_sim_s=100.0),
                                     "cheaper": trials(16, 4, wall_per_sim_s=50.0),
                                     "weak": trials(17, 3, wall_per_sim_s=20.0)}, "fine")
    assert grasp_front.cheapest_agreeing(front) == "weak"  # on success alone
    assert grasp_front.cheapest_agreeing(front, table.reset_index()) == "cheaper"  # `weak` loses its toughness


def test_the_script_writes_its_tables_and_names_a_bad_argument(tmp_path):
    for label, frame in (("fine", trials(17, 3, timestep_s=1.25e-4)), ("coarse", trials(15, 5))):
        write_trials(frame, tmp_path / label)
    script = [sys.executable, str(ROOT / "scripts" / "grasp_front.py"), "--out", str(tmp_path / "front")]
    done = subprocess.run([*script, "--fine", f"fine={tmp_path / 'fine'}", "--variant",
                           f"coarse={tmp_path / 'coarse'}"], capture_output=True, text=True, check=True)
    assert "| coarse | euler | 0.25 |" in done.stdout
    assert "Cheapest variant that agrees with the fine run: coarse" in done.stdout
    written = pd.read_csv(tmp_path / "front" / "front.csv")
    assert written["verdict"].tolist() == ["fine run", "agrees"]
    assert (tmp_path / "front" / "front.png").stat().st_size > 0
    bad = subprocess.run([*script, "--fine", str(tmp_path / "fine")], capture_output=True, text=True)
    assert bad.returncode == 2 and "expected LABEL=FOLDER" in bad.stderr
    elsewhere = subprocess.run([*script, "--fine", f"fine={tmp_path / 'fine'}", "--offset", "0.01"],
                               capture_output=True, text=True)
    assert elsewhere.returncode == 2 and "no rows of top_drape/eight_branch_tree at offset 0.01 m in: fine" in (
        elsewhere.stderr)
