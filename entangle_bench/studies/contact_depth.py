"""Does a grasp lean on penetration? The deepest contact and the load deep contacts carry, per task phase.

`ContactDepth` is an observer (`observers.Observer`): after every control step it keeps, for the phase that
step ran in, the deepest contact (m, with its geom pair and time) and the filament–object normal force summed
over contacts (N, summed over control steps), in all and in contacts deeper than `deep_m`. A hold carried by
embedded filaments shows a large deep share in `hold`. Use it through `contact_depth_by_phase`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import pandas as pd

from entangle_bench.runner import TrialResult, simulate


@dataclass
class _PhaseDepth:
    deepest_m: float = 0.0
    where: str = ""
    deep_force_n: float = 0.0
    force_n: float = 0.0


class ContactDepth:
    """Observer: per phase, the deepest contact and the filament–object normal force by depth."""

    def __init__(self, deep_m: float) -> None:
        self.deep_m = deep_m
        self.phases: dict[str, _PhaseDepth] = {}
        self._names: list[str] = []

    def start(self, env: Any) -> None:
        model = env.physics.model.ptr
        self._names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)]

    def step(self, env: Any) -> None:
        physics = env.physics
        model, data = physics.model.ptr, physics.data.ptr
        load = self.phases.setdefault(env.task.phase(physics), _PhaseDepth())
        force = np.zeros(6)
        kinds = physics.scene.geoms.kinds(data.contact.geom[: data.ncon])
        for i in range(data.ncon):
            contact = data.contact[i]
            depth = -float(contact.dist)
            if depth > load.deepest_m:
                load.deepest_m = depth
                load.where = f"{self._names[contact.geom1]} / {self._names[contact.geom2]} at {physics.time():.2f} s"
            if kinds[i] == "filament-object":
                mujoco.mj_contactForce(model, data, i, force)
                load.force_n += force[0]
                if depth > self.deep_m:
                    load.deep_force_n += force[0]

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to write: the table is read with `table`."""

    def table(self) -> pd.DataFrame:
        """One row per phase: deepest contact (m) and where, and the deep share of the filament–object normal
        force (0–1; 0 where no filament touched the object)."""
        return pd.DataFrame([
            {
                "phase": name,
                "deepest_m": load.deepest_m,
                "where": load.where,
                "deep_share": load.deep_force_n / load.force_n if load.force_n > 0 else 0.0,
                "force_n_steps": load.force_n,
            }
            for name, load in self.phases.items()
        ])


def contact_depth_by_phase(task: str, config: Any, seed: int, deep_m: float) -> tuple[TrialResult, pd.DataFrame]:
    """Run one trial under `ContactDepth(deep_m)`; its result and the per-phase table (see `ContactDepth.table`)."""
    observer = ContactDepth(deep_m)
    result = simulate(task, config, seed, observers=[observer])
    return result, observer.table()
