"""Classification of active MuJoCo contacts: which filaments touch the object, each other, the ground.

Geoms are classified by the scene naming conventions: filament i's capsules are `f{i:02d}_g{j:03d}`,
the object's geoms `object_*`, the ground plane `ground`. Contact kinds:
filament-object, filament-filament (two different filaments), filament-self (two geoms of one
filament), filament-ground, object-ground, and other (anything else, e.g. hub or object-object).
Normal forces come from `mujoco.mj_contactForce` (contact frame, first component, N).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.errors import ParameterError

KINDS = (
    "filament-object",
    "filament-filament",
    "filament-self",
    "filament-ground",
    "object-ground",
    "other",
)

_FILAMENT_GEOM = re.compile(r"^f(\d{2})_g(\d{3})$")


@dataclass(frozen=True)
class ContactSummary:
    """Active contacts of one MuJoCo state, classified by kind (points in m, forces in N)."""

    counts: dict[str, int]  # number of contacts per kind, every kind in KINDS present
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


def geom_classes(model: mujoco.MjModel) -> tuple[np.ndarray, np.ndarray]:
    """Per-geom filament index (-1 if none) and object flag, parsed from the geom names."""
    filament_of_geom = np.full(model.ngeom, -1, dtype=np.int64)
    is_object_geom = np.zeros(model.ngeom, dtype=bool)
    for g in range(model.ngeom):
        name = model.geom(g).name
        match = _FILAMENT_GEOM.match(name)
        if match:
            filament_of_geom[g] = int(match.group(1))
        is_object_geom[g] = name.startswith("object_")
    return filament_of_geom, is_object_geom


def classify_geom_pairs(
    geom_pairs: np.ndarray,
    filament_of_geom: np.ndarray,
    is_object_geom: np.ndarray,
    is_ground_geom: np.ndarray,
) -> np.ndarray:
    """Contact kind (one of KINDS) of each geom pair (n, 2), from per-geom class arrays."""
    pairs = np.asarray(geom_pairs, dtype=np.int64).reshape(-1, 2)
    f1, f2 = filament_of_geom[pairs[:, 0]], filament_of_geom[pairs[:, 1]]
    o1, o2 = is_object_geom[pairs[:, 0]], is_object_geom[pairs[:, 1]]
    g1, g2 = is_ground_geom[pairs[:, 0]], is_ground_geom[pairs[:, 1]]
    fil1, fil2 = f1 >= 0, f2 >= 0
    kinds = np.full(len(pairs), "other", dtype=object)
    kinds[fil1 & fil2 & (f1 == f2)] = "filament-self"
    kinds[fil1 & fil2 & (f1 != f2)] = "filament-filament"
    kinds[(fil1 & o2) | (fil2 & o1)] = "filament-object"
    kinds[(fil1 & g2) | (fil2 & g1)] = "filament-ground"
    kinds[(o1 & g2) | (o2 & g1)] = "object-ground"
    return kinds.astype(str)


def contact_summary(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    filament_of_geom: np.ndarray,
    is_object_geom: np.ndarray,
    *,
    ground_name: str = "ground",
) -> ContactSummary:
    """Classify the active contacts of `data` (those with constraint rows) and their normal forces.

    `filament_of_geom` (ngeom,) holds each geom's filament index or -1, `is_object_geom` (ngeom,)
    flags object geoms (see `geom_classes`); the geom named `ground_name` is the ground, if any.
    A filament-filament contact counts for both filaments in `per_filament`, a self contact once.
    """
    filament_of_geom = np.asarray(filament_of_geom)
    is_object_geom = np.asarray(is_object_geom)
    if filament_of_geom.shape != (model.ngeom,) or not np.issubdtype(
        filament_of_geom.dtype, np.integer
    ):
        raise ParameterError(
            f"filament_of_geom must be an int array of shape ({model.ngeom},), "
            f"got {filament_of_geom.dtype} {filament_of_geom.shape}"
        )
    if is_object_geom.shape != (model.ngeom,) or is_object_geom.dtype != bool:
        raise ParameterError(
            f"is_object_geom must be a bool array of shape ({model.ngeom},), "
            f"got {is_object_geom.dtype} {is_object_geom.shape}"
        )
    is_ground_geom = np.zeros(model.ngeom, dtype=bool)
    ground = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, ground_name)
    if ground >= 0:
        is_ground_geom[ground] = True

    contacts = data.contact
    active = np.flatnonzero(np.asarray(contacts.efc_address[: data.ncon]) >= 0)
    geom_pairs = np.asarray(contacts.geom[: data.ncon], dtype=np.int64)[active].reshape(-1, 2)
    points = np.asarray(contacts.pos[: data.ncon], dtype=np.float64)[active].reshape(-1, 3)
    forces = np.zeros(len(active))
    wrench = np.zeros(6)
    for n, i in enumerate(active):
        mujoco.mj_contactForce(model, data, int(i), wrench)
        forces[n] = abs(wrench[0])
    kinds = classify_geom_pairs(geom_pairs, filament_of_geom, is_object_geom, is_ground_geom)

    n_filaments = int(filament_of_geom.max()) + 1 if model.ngeom else 0
    f1, f2 = filament_of_geom[geom_pairs[:, 0]], filament_of_geom[geom_pairs[:, 1]]
    involved = np.concatenate([f1[f1 >= 0], f2[(f2 >= 0) & (f2 != f1)]])
    per_filament = np.bincount(involved, minlength=max(n_filaments, 0))
    return ContactSummary(
        counts={kind: int(np.count_nonzero(kinds == kind)) for kind in KINDS},
        per_filament=per_filament,
        points=points,
        normal_forces_n=forces,
        kinds=kinds,
        geom_pairs=geom_pairs,
    )
