"""Pull-rate study: the same seeds at each speed, bad speeds refused before running, tables written."""

import pandas as pd
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.studies.pull_rate import SPEED, rate_specs, run_pull_rate
from entangle_bench.suite import SHORT_PULL_SEQUENCE
from scripts.pull_rate import main


def test_same_seeds_at_each_speed_and_bad_speeds_refused():
    specs = rate_specs(["sphere", "cube"], [0.03, 0.01], 2, preset="fast")
    assert len(specs) == 8 and {s.seed for s in specs} == {0, 1}
    assert [s.config.pull.speed_m_s for s in specs[:4]] == [0.01, 0.01, 0.03, 0.03]
    assert specs[0].condition == "sphere v=0.01 m/s"
    assert specs[0].config.gripper == specs[2].config.gripper  # only the speed differs
    with pytest.raises(ParameterError, match="two different pull speeds"):
        rate_specs(["sphere"], [0.01, 0.01], 1)
    with pytest.raises(ParameterError, match=r"pull.speed_m_s = 0.0 is outside"):
        rate_specs(["sphere"], [0.0, 0.01], 1)
    assert main(["--speeds", "0", "0.01", "--objects", "sphere"]) == 2


def test_study_writes_the_tables(tmp_path):
    short = [s for s in SHORT_PULL_SEQUENCE if not s.startswith("pull.speed_m_s")]
    specs = rate_specs(["sphere"], [0.05, 0.1], 1, preset="fast", overrides=short)
    study = run_pull_rate(specs, tmp_path, progress=False)
    assert list(study.table[SPEED]) == [0.05, 0.1] and study.agreement.loc[0, "speed_ratio"] == 2.0
    assert set(pd.read_csv(tmp_path / "pull_rate_agreement.csv")) >= {"peak_force_agrees", "toughness_agrees"}
