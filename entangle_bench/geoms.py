"""Geom classification: the one place that says which geom is a filament, the object or the ground.

Scenes name their geoms by convention: filament i's capsules `f{i:02d}_g{j:03d}` (`filament.geom_name`), the
object's geoms `object_*`, the ground plane `ground` and the post an object may stand on `ground_post` (both
ground); anything else (the hub disk) is `other`. A pair of geoms is of one contact kind (`KINDS`, the names used
in result columns such as `held.contacts.filament-object`): filament-object, filament-filament (two different
filaments), filament-self (two geoms of one filament), filament-ground, object-ground, and other. Collision
pairs (`effects.pair_kinds`), active contacts (`metrics.contacts`) and observations all classify through
`GeomClasses`.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.errors import ParameterError

ROLES = ("filament", "object", "ground", "other")

#: Name of the post an object may stand on (`scene.SceneConfig.post_height_m`), a ground geom.
POST = "ground_post"

KINDS = (
    "filament-object",
    "filament-filament",
    "filament-self",
    "filament-ground",
    "object-ground",
    "other",
)

_FILAMENT_GEOM = re.compile(r"^f(\d+)_g(\d+)$")


def role_of(name: str) -> tuple[str, int]:
    """Role (one of ROLES) of the geom called `name` and its filament index (-1 unless a filament geom)."""
    match = _FILAMENT_GEOM.match(name)
    if match:
        return "filament", int(match.group(1))
    if name.startswith("object_"):
        return "object", -1
    if name in ("ground", POST):
        return "ground", -1
    return "other", -1


@dataclass(frozen=True, eq=False)
class GeomClasses:
    """Per-geom classes of one compiled model: filament index (-1: none), object flag, ground flag."""

    filament: np.ndarray
    """(ngeom,) int filament index of each geom, -1 for non-filament geoms."""
    is_object: np.ndarray
    """(ngeom,) bool, True for the object's geoms."""
    is_ground: np.ndarray
    """(ngeom,) bool, True for the ground plane and the post an object may stand on."""

    def __post_init__(self) -> None:
        filament = np.asarray(self.filament)
        if filament.ndim != 1 or not np.issubdtype(filament.dtype, np.integer):
            raise ParameterError(f"GeomClasses.filament must be a 1-D int array, got {filament.dtype} {filament.shape}")
        for name in ("is_object", "is_ground"):
            flags = np.asarray(getattr(self, name))
            if flags.shape != filament.shape or flags.dtype != bool:
                raise ParameterError(
                    f"GeomClasses.{name} must be a bool array of shape {filament.shape}, "
                    f"got {flags.dtype} {flags.shape}"
                )

    @classmethod
    def from_names(cls, names: Iterable[str]) -> GeomClasses:
        """Classes of geoms named `names` (in geom id order) by the scene naming conventions."""
        roles = [role_of(name) for name in names]
        return cls(
            filament=np.array([index for _, index in roles], dtype=np.int64),
            is_object=np.array([role == "object" for role, _ in roles], dtype=bool),
            is_ground=np.array([role == "ground" for role, _ in roles], dtype=bool),
        )

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> GeomClasses:
        """Classes of every geom of a compiled model, from its geom names."""
        return cls.from_names(model.geom(g).name for g in range(model.ngeom))

    @property
    def n_geoms(self) -> int:
        """Number of classified geoms."""
        return len(self.filament)

    @property
    def n_filaments(self) -> int:
        """Number of filaments (largest filament index + 1; 0 without filaments)."""
        return int(self.filament.max()) + 1 if self.n_geoms else 0

    def check_model(self, model: mujoco.MjModel) -> None:
        """Raise ParameterError unless these classes describe `model`'s geoms (same count)."""
        if self.n_geoms != model.ngeom:
            raise ParameterError(f"geom classes describe {self.n_geoms} geoms, the model has {model.ngeom}")

    def kinds(self, geom_pairs: np.ndarray) -> np.ndarray:
        """Contact kind (one of KINDS) of each geom pair (n, 2)."""
        pairs = np.asarray(geom_pairs, dtype=np.int64).reshape(-1, 2)
        f1, f2 = self.filament[pairs[:, 0]], self.filament[pairs[:, 1]]
        o1, o2 = self.is_object[pairs[:, 0]], self.is_object[pairs[:, 1]]
        g1, g2 = self.is_ground[pairs[:, 0]], self.is_ground[pairs[:, 1]]
        fil1, fil2 = f1 >= 0, f2 >= 0
        kinds = np.full(len(pairs), "other", dtype=object)
        kinds[fil1 & fil2 & (f1 == f2)] = "filament-self"
        kinds[fil1 & fil2 & (f1 != f2)] = "filament-filament"
        kinds[(fil1 & o2) | (fil2 & o1)] = "filament-object"
        kinds[(fil1 & g2) | (fil2 & g1)] = "filament-ground"
        kinds[(o1 & g2) | (o2 & g1)] = "object-ground"
        return kinds.astype(str)

    def count_kinds(self, geom_pairs: np.ndarray) -> dict[str, int]:
        """Number of geom pairs (n, 2) of each kind, every kind of KINDS present (zeros included)."""
        kinds = self.kinds(geom_pairs)
        return {kind: int(np.count_nonzero(kinds == kind)) for kind in KINDS}


def lowest_z(model: mujoco.MjModel, data: mujoco.MjData, geom_ids: np.ndarray) -> float:
    """Height of the lowest surface point of the geoms `geom_ids` in the current pose (after kinematics), m.

    Exact for spheres, capsules, cylinders, boxes and meshes (their vertices: MuJoCo collides a mesh by its
    convex hull, whose lowest point is a vertex); any other type is bounded below by its bounding box.
    """
    ids = np.asarray(geom_ids, dtype=int)
    kind, size = model.geom_type[ids], model.geom_size[ids]
    up = data.geom_xmat[ids].reshape(-1, 3, 3)[:, 2, :]  # world z of each geom axis
    centre = data.geom_xpos[ids, 2]
    tilt = np.abs(up[:, 2])
    g = mujoco.mjtGeom
    low = np.select(
        [kind == g.mjGEOM_SPHERE, kind == g.mjGEOM_CAPSULE, kind == g.mjGEOM_CYLINDER, kind == g.mjGEOM_BOX],
        [
            centre - size[:, 0],
            centre - tilt * size[:, 1] - size[:, 0],
            centre - tilt * size[:, 1] - size[:, 0] * np.sqrt(np.clip(1.0 - tilt**2, 0.0, 1.0)),
            centre - np.einsum("gj,gj->g", np.abs(up), size),
        ],
        default=centre + np.einsum("gj,gj->g", up, model.geom_aabb[ids, :3])
        - np.einsum("gj,gj->g", np.abs(up), model.geom_aabb[ids, 3:]),
    )
    for i in np.flatnonzero(kind == g.mjGEOM_MESH):
        mesh = model.geom_dataid[ids[i]]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        low[i] = centre[i] + float(np.min(model.mesh_vert[start : start + count] @ up[i]))
    return float(np.min(low))
