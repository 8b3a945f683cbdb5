"""Stage profile of a trial: its bookkeeping against the trial itself and MuJoCo's own step counter."""

import mujoco
import pytest

from entangle_bench.studies.profile import STAGES, profile_trial, solver_load
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


ISLANDS_XML = """
<mujoco>
  <option solver="CG"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="-0.3 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05"/></body>
    <body pos="0.3 0 0.049"><freejoint/><geom type="box" size="0.05 0.05 0.05"/></body>
  </worldbody>
</mujoco>
"""


def test_solver_load_counts_every_constraint_island():
    model = mujoco.MjModel.from_xml_string(ISLANDS_XML)
    data = mujoco.MjData(model)
    for _ in range(5):
        mujoco.mj_step(model, data)
    # Two boxes resting apart: two islands, each with its own solve and statistics.
    niter = [int(k) for k in data.solver_niter[:2]]
    assert data.nisland == 2 and min(niter) > 0
    iterations, worst = solver_load(data)
    assert iterations == sum(niter) > niter[0]  # slot 0 alone (what the profile read before) misses island 1
    last = [data.solver[i * mujoco.mjNSOLVER + k - 1].improvement for i, k in enumerate(niter)]
    assert worst == max(last)
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    mujoco.mj_step(model, data)
    assert data.nisland == 0 and solver_load(data)[0] == data.solver_niter[0] > 0
