"""Active MuJoCo contacts by kind: which filaments touch the object, each other, the ground.

Kinds and geom classes come from `entangle_bench.geoms` (one vocabulary: filament-object, filament-filament,
filament-self, filament-ground, object-ground, other). Normal forces come from `mujoco.mj_contactForce`
(contact frame, first component, N).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.errors import ParameterError
from entangle_bench.geoms import KINDS, GeomClasses


@dataclass(frozen=True)
class ContactSummary:
    """Active contacts of one MuJoCo state, classified by kind (points in m, forces in N)."""

    counts: dict[str, int]  # number of contacts per kind, every kind in geoms.KINDS present
    per_filament: np.ndarray  # (K,) int, contacts each filament takes part in
    points: np.ndarray  # (n, 3) contact positions, m
    normal_forces_n: np.ndarray  # (n,) normal force magnitudes, N
    kinds: np.ndarray  # (n,) str, kind of each contact
    geom_pairs: np.ndarray  # (n, 2) int, the two geoms of each contact

    def normal_force_sum_n(self, kind: str) -> float:
        """Sum of normal force magnitudes (N) over the contacts of one kind."""
        if kind not in KINDS:
            raise ParameterError(f"contact kind {kind!r} is not one of {list(KINDS)}")
        return float(self.normal_forces_n[self.kinds == kind].sum())


def contact_summary(
    model: mujoco.MjModel, data: mujoco.MjData, geoms: GeomClasses | None = None
) -> ContactSummary:
    """Classify the active contacts of `data` (those with constraint rows) and their normal forces (N).

    `geoms` classifies the model's geoms (a scene's `Scene.geoms`; default: from the geom names). A
    filament-filament contact counts for both filaments in `per_filament`, a self contact once.
    """
    geoms = GeomClasses.from_model(model) if geoms is None else geoms
    geoms.check_model(model)
    contacts = data.contact
    active = np.flatnonzero(np.asarray(contacts.efc_address[: data.ncon]) >= 0)
    geom_pairs = np.asarray(contacts.geom[: data.ncon], dtype=np.int64)[active].reshape(-1, 2)
    points = np.asarray(contacts.pos[: data.ncon], dtype=np.float64)[active].reshape(-1, 3)
    forces = np.zeros(len(active))
    wrench = np.zeros(6)
    for n, i in enumerate(active):
        mujoco.mj_contactForce(model, data, int(i), wrench)
        forces[n] = abs(wrench[0])
    kinds = geoms.kinds(geom_pairs)
    filament = geoms.filament
    f1, f2 = filament[geom_pairs[:, 0]], filament[geom_pairs[:, 1]]
    involved = np.concatenate([f1[f1 >= 0], f2[(f2 >= 0) & (f2 != f1)]])
    per_filament = np.bincount(involved, minlength=geoms.n_filaments)
    return ContactSummary(
        counts={kind: int(np.count_nonzero(kinds == kind)) for kind in KINDS},
        per_filament=per_filament,
        points=points,
        normal_forces_n=forces,
        kinds=kinds,
        geom_pairs=geom_pairs,
    )
