"""Contact-depth study: its per-phase bookkeeping against an independent scan of the same control steps."""

import pytest

from entangle_bench.runner import simulate
from entangle_bench.studies.contact_depth import ContactDepth


class Deepest:
    """Observer: the deepest contact over all control steps, scanned directly from mjData."""

    def __init__(self):
        self.deepest_m = 0.0

    def start(self, env):
        pass

    def step(self, env):
        data = env.physics.data.ptr
        if data.ncon:
            self.deepest_m = max(self.deepest_m, -float(data.contact.dist[: data.ncon].min()))

    def finish(self, row, complete):
        pass


def test_phases_hold_the_deepest_contact_and_split_the_force_by_depth(short_spec):
    spec = short_spec("eight_branch_tree")
    scan, everything, nothing = Deepest(), ContactDepth(0.0), ContactDepth(1.0)
    result = simulate(spec.task, spec.config, spec.seed, observers=[scan, everything, nothing])
    assert result.stable
    table = everything.table()
    assert set(table["phase"]) >= {"approach", "actuate"}
    # The deepest contact of the trial is in exactly one phase's record, with its geom pair and time.
    assert table["deepest_m"].max() == pytest.approx(scan.deepest_m, rel=1e-12)
    assert scan.deepest_m >= result.row["max_penetration_m"] > 0
    assert table.loc[table["deepest_m"].idxmax(), "where"].count(" / ") == 1
    # Filaments pressed on the tree: every contact is deeper than 0 m and none is deeper than 1 m.
    touched = table["force_n_steps"] > 0
    assert touched.any()
    assert (table.loc[touched, "deep_share"] == 1.0).all()
    assert (nothing.table()["deep_share"] == 0.0).all()
    assert nothing.table()["force_n_steps"].tolist() == pytest.approx(table["force_n_steps"].tolist(), rel=1e-12)
