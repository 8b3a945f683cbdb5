"""The pull-out experiment's results on disk: a trial's force-displacement curve and a run's report.

Every pull-out trial (`suite.pullout`) saves its curve beside its states as `states/<trial_id>_series.npz`
(`runner.state_path`): one entry per control step of the pull, from its start, holding `time_s` and the fields of
`metrics.pullout.CurvePoint` (vectors as `<name>.x|y|z`, contact counts as `contacts.<kind>`). Read it with the
one function `read_curve`:

    curve = read_curve("results/pullout_sphere/states/0123456789abcdef_series.npz")
    curve.displacement_m, curve.pull_force_n     # the force-displacement curve, m and N

`write_report(rows, folder)` writes a run's pull-out summary `pullout.csv` (`metrics.pullout.pullout_table`), the
force-displacement curves overlaid per condition `pullout_curves.png`, and the toughness chart with bootstrap
intervals beside the reference's values `pullout_toughness.png`.
"""

from __future__ import annotations

import dataclasses
import os
import typing
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from entangle_bench.errors import FileFormatError
from entangle_bench.geoms import KINDS
from entangle_bench.metrics.curve_file import open_npz
from entangle_bench.metrics.pullout import CurvePoint, pullout_table
from entangle_bench.plots import plot_pull_curves, plot_toughness
from entangle_bench.results import UNSTABLE, atomic_write_csv
from entangle_bench.runner import state_path


@dataclass(frozen=True, eq=False)
class PullCurve:
    """One trial's pull-out curve: arrays over the control steps of the pull (SI units, world frame)."""

    path: Path
    time_s: np.ndarray
    """(n,) simulated time, s."""
    displacement_m: np.ndarray
    """(n,) hub displacement along the pull direction since the pull began, m."""
    pull_force_n: np.ndarray
    """(n,) force the gripper exerts on the object along the pull direction (holding weld), N."""
    contact_pull_force_n: np.ndarray
    """(n,) the same from the filament-object contact forces, N."""
    ground_pinch_pull_force_n: np.ndarray
    """(n,) the part of it through filament segments that also touch the ground, N (NaN in curves logged before
    it was)."""
    force_n: np.ndarray
    """(n, 3) force the gripper exerts on the object (holding weld), N."""
    contact_force_n: np.ndarray
    """(n, 3) sum of the filament-object contact forces on the object, N."""
    weld_force_n: np.ndarray
    """(n, 3) force the holding weld exerts on the object, N."""
    contacts: dict[str, np.ndarray]
    """Active contacts by kind (`geoms.KINDS`), (n,) each."""
    hub_work_j: np.ndarray
    """(n,) work the hub has done on the filaments since the pull began, J."""
    damping_loss_j: np.ndarray
    """(n,) energy the joint dampers have dissipated since the pull began, J."""
    constraint_work_j: np.ndarray
    """(n,) work of the constraint forces since the pull began, J (< 0: dissipated)."""
    mechanical_energy_j: np.ndarray
    """(n,) gravity, elastic and kinetic energy of everything but the hub, J."""


#: Curve columns added after curves were logged: read as NaN from files that lack them.
ADDED_COLUMNS = frozenset({"ground_pinch_pull_force_n"})


def read_curve(path: str | os.PathLike) -> PullCurve:
    """Read a pull-out trial's curve (`states/<trial_id>_series.npz`); FileFormatError names file and key."""
    path = Path(path)
    with open_npz(path) as archive:

        def column(key: str) -> np.ndarray:
            if key in ADDED_COLUMNS and key not in archive.files:
                return np.full(archive["time_s"].shape, np.nan)
            if key not in archive.files:
                raise FileFormatError(f"{path}: key {key!r} is missing: not a pull-out curve")
            values = np.asarray(archive[key], dtype=float)
            if values.shape != archive["time_s"].shape or values.ndim != 1:
                raise FileFormatError(f"{path}: key {key!r}: shape {values.shape}, expected {archive['time_s'].shape}")
            return values

        fields: dict[str, object] = {"path": path, "time_s": column("time_s")}
        hints = typing.get_type_hints(CurvePoint)
        for field in dataclasses.fields(CurvePoint):
            if field.name == "contacts":
                fields["contacts"] = {kind: column(f"contacts.{kind}") for kind in KINDS}
            elif hints[field.name] is np.ndarray:
                fields[field.name] = np.stack([column(f"{field.name}.{axis}") for axis in "xyz"], axis=1)
            else:
                fields[field.name] = column(field.name)
    return PullCurve(**fields)


def write_report(rows: pd.DataFrame, folder: str | os.PathLike, seed: int = 0) -> list[Path]:
    """Pull-out summary (`pullout.csv`), overlaid curves and toughness chart of a run's rows; the paths written.

    `rows` are the run's trial rows (other tasks' rows are left out); curves are read from `folder/states`, and
    only stable trials' curves are drawn.
    """
    folder = Path(folder)
    pulls = rows[rows["task"].str.startswith("pullout/")]
    if pulls.empty:
        return []
    table = pullout_table(pulls, ["condition", "config.object_name"], seed=seed)
    paths = [folder / "pullout.csv", folder / "pullout_curves.png", folder / "pullout_toughness.png"]
    atomic_write_csv(table, paths[0])
    curves: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for _, row in pulls[pulls["outcome"] != UNSTABLE].iterrows():
        path = state_path(folder / "states", row["trial_id"], "series")
        if path.exists():
            curve = read_curve(path)
            curves.setdefault(row["condition"], []).append((curve.displacement_m, curve.pull_force_n))
    plot_pull_curves(curves, paths[1])
    plot_toughness(table, paths[2])
    return paths
