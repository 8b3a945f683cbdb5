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


@dataclass(frozen=True)
class ObjectSupport:
    """Forces on the object in one state, world frame, N: what carries it and how.

    `by_part` sums the forces filaments exert on each object geom (named by its part, e.g. 'branch03');
    contacts of a filament segment that touches two or more object geoms at once go to `pinched` instead
    (a segment squeezed between two faces of one rigid object is a clamp, not a grasp), and those of a segment
    that also touches the ground go to `ground_pinched` (a segment squeezed between the object and the ground
    passes the ground's support on; it carries nothing once the object is lifted); `ground` is the ground's
    own force on the object; `filament_filament_n` the summed normal force between different filaments
    (the entanglement network's internal load).
    """

    by_part: dict[str, np.ndarray]
    pinched: np.ndarray
    ground: np.ndarray
    filament_filament_n: float
    ground_pinched: np.ndarray

    @property
    def filament_total(self) -> np.ndarray:
        """(3,) everything the filaments exert on the object, pinches included, N."""
        return sum(self.by_part.values(), self.pinched + self.ground_pinched)


def object_support(model: mujoco.MjModel, data: mujoco.MjData, geoms: GeomClasses) -> ObjectSupport:
    """Forces on the object by source in the current state (active contacts only), world frame, N.

    `mj_contactForce` gives each contact's force in its contact frame (rows: normal from geom1 to geom2, then
    the tangents), the force on geom2; the force on geom1 is its opposite.
    """
    contacts = data.contact
    active = np.flatnonzero(np.asarray(contacts.efc_address[: data.ncon]) >= 0)
    pairs = np.asarray(contacts.geom[: data.ncon], dtype=np.int64)[active].reshape(-1, 2)
    wrench = np.zeros(6)
    on_object: list[tuple[int, int, np.ndarray]] = []  # (object geom, other geom, force on the object)
    ground, ff = np.zeros(3), 0.0
    on_ground: set[int] = set()  # filament geoms touching the ground
    for i, (g1, g2) in zip(active, pairs):
        obj1, obj2 = geoms.is_object[g1], geoms.is_object[g2]
        f1, f2 = geoms.filament[g1], geoms.filament[g2]
        if (geoms.is_ground[g1] and f2 >= 0) or (geoms.is_ground[g2] and f1 >= 0):
            on_ground.add(int(g2 if f2 >= 0 else g1))
            continue
        if not (obj1 or obj2 or (f1 >= 0 and f2 >= 0 and f1 != f2)):
            continue
        mujoco.mj_contactForce(model, data, int(i), wrench)
        if not (obj1 or obj2):
            ff += abs(wrench[0])
            continue
        force = contacts.frame[i].reshape(3, 3).T @ wrench[:3]
        obj, other, force = (g2, g1, force) if obj2 else (g1, g2, -force)
        if geoms.is_ground[other]:
            ground += force
        elif geoms.filament[other] >= 0:
            on_object.append((obj, other, force))
    touched: dict[int, set[int]] = {}
    for obj, other, _ in on_object:
        touched.setdefault(other, set()).add(obj)
    by_part: dict[str, np.ndarray] = {}
    pinched, ground_pinched = np.zeros(3), np.zeros(3)
    for obj, other, force in on_object:
        if len(touched[other]) > 1:
            pinched += force
        elif other in on_ground:
            ground_pinched += force
        else:
            part = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, obj).removeprefix("object_")
            by_part[part] = by_part.get(part, np.zeros(3)) + force
    return ObjectSupport(by_part, pinched, ground, ff, ground_pinched)
