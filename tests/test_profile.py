"""Stage profile of a trial: its bookkeeping against the trial itself and MuJoCo's own step counter."""

import pytest

from entangle_bench.studies.profile import STAGES, profile_trial
from entangle_bench.studies.stability_map import PROBE_TASK, probe_config


def test_profile_accounts_for_every_step_and_its_stages():
    config = probe_config("euler", 12, 1e6, 2e-3, duration_s=0.4)
    result, table = profile_trial(PROBE_TASK, config, seed=0)
    assert result.stable
    phases = table[table["phase"] != "all"]
    total = table[table["phase"] == "all"].iloc[0]
    # Every simulated second is in exactly one phase, and the phases add up to the trial.
    assert phases["sim_s"].sum() == pytest.approx(total["sim_s"])
    assert total["sim_s"] == pytest.approx(result.row["sim_time_s"], abs=config.numerics.timestep_s)
    # The top-level stages of mj_step are disjoint parts of it: together at most the whole step.
    parts = ["position", "velocity", "constraint_solver", "advance"]
    assert set(parts) < set(STAGES)
    for _, row in table.iterrows():
        shares = sum(row[f"{p}_pct"] for p in parts)
        assert 0 < shares <= 100.0 + 1e-6
        assert 0 <= row["python_share_pct"] < 100
        assert row["us_per_step"] > 0 and row["wall_per_sim_s"] > 0
