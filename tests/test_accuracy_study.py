"""The accuracy-time study (`entangle_bench.studies.accuracy_time`) in its CI smoke mode, and its Pareto helper."""

from __future__ import annotations

import numpy as np
import pandas as pd

from entangle_bench.studies import accuracy_time


def test_pareto_mask():
    cost = np.array([1.0, 2.0, 3.0, 2.5, 1.0])
    error = np.array([5.0, 2.0, 1.0, 3.0, 6.0])
    # (2.5, 3) is dominated by (2, 2); (1, 6) by (1, 5).
    np.testing.assert_array_equal(accuracy_time.pareto_mask(cost, error), [True, True, True, False, False])


def test_smoke_mode_writes_tables_and_plot(tmp_path):
    report = accuracy_time.run_study(tmp_path, smoke=True)
    for name in ("rods.csv", "trial.csv", "pareto.png", "report.md"):
        assert (tmp_path / name).stat().st_size > 0
    rods = pd.read_csv(tmp_path / "rods.csv")
    static = rods[(rods["kind"] == "static") & (rods["representation"] == "ball")]
    # 8-segment chain: measured 5.9e-3 L on both smoke cases; second order in ds, so well under 2e-2.
    assert set(static["case"]) == {"soft_cantilever", "arc_zero_gravity"}
    assert (static["error_max"] < 2e-2).all() and (static["error_max"] > 1e-4).all()
    flex = rods[(rods["representation"] == "flex1d") & (rods["case"] == "arc_zero_gravity")]
    assert flex["note"].str.contains("straight reference").all()
    trial = pd.read_csv(tmp_path / "trial.csv")
    assert len(trial) == 2 and (trial["cpu_per_sim_s"] > 0).all()
    # Trials run through the runner: a classified outcome and the held snapshot's metrics.
    assert set(trial["outcome"]) <= {"success", "failure"}
    assert trial["acn"].notna().all() and (trial["acn"] > 0).all()
    assert "Rod statics" in report and report == (tmp_path / "report.md").read_text().rstrip("\n")
