"""Target objects by name (`catalog.OBJECTS`) and the single entry point that adds one to an MjSpec.

Trees and primitives register next to their builders; the Dex-Net meshes are registered here.

Body convention: one free body `object` whose origin lies on the object's vertical axis (the trunk
axis of trees, otherwise the centre of the bounding box in x and y) at its lowest point, so
`pos=(x, y, 0)` sets it on the ground.
Mass and inertia are set explicitly from the union of the parts (see geometry.union_moments) or,
for mesh objects, from the source mesh; geoms carry no mass of their own.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from entangle_bench.errors import ParameterError
from entangle_bench.objects import meshes, primitives, trees  # noqa: F401  (trees and primitives register)
from entangle_bench.objects.catalog import OBJECTS, register_object
from entangle_bench.objects.geometry import (
    Box,
    Capsule,
    ConvexMesh,
    Cylinder,
    Part,
    Sphere,
    hull_points,
    hull_volume,
    union_moments,
)

_DEXNET = {
    # mesh stem: CoACD settings chosen so that the union of the parts is within 5 % of the mesh
    # volume; masses from the default 1000 kg/m^3 (plastic parts). pawn.obj is not watertight
    # (two flat fragments) and is repaired on load. Thin-walled meshes (gearbox, mount1, part1)
    # are left out: even 96 parts overshoot their volume by more than 10 %.
    "bar_clamp": meshes.CoacdSettings(threshold=0.03, max_convex_hull=64),
    "climbing_hold": meshes.CoacdSettings(),
    "endstop_holder": meshes.CoacdSettings(),
    "pawn": meshes.CoacdSettings(),
}

for _stem, _settings in _DEXNET.items():
    register_object(
        f"dexnet_{_stem}",
        meshes.MeshObjectParams(f"dexnet/{_stem}.obj", coacd=_settings),
        f"Dex-Net 2.0 adversarial mesh {_stem} (CC, see assets/dexnet/SOURCE.md)",
        tags=("mesh",),
    )(meshes.build_mesh_object)


@dataclasses.dataclass(frozen=True)
class ObjectInfo:
    """Summary of a built object (SI units, body frame described in the module docstring).

    radius_m: largest horizontal distance from the vertical axis; volume_m3: volume enclosed by the
    object's surface; phi_t = volume / convex-hull volume (effective volumetric density);
    n_parts: collision geoms (convex parts for meshes); dims: named dimensions (m).
    """

    name: str
    mass_kg: float
    height_m: float
    radius_m: float
    volume_m3: float
    hull_volume_m3: float
    phi_t: float
    n_parts: int
    dims: dict[str, float]
    geom_names: tuple[str, ...]
    center_of_mass_m: tuple[float, float, float]
    inertia_kg_m2: tuple[tuple[float, float, float], ...]
    notes: tuple[str, ...] = ()
    orientation_free: bool = False
    """Every orientation is the same object (a ball): the upright criterion does not apply."""


@dataclasses.dataclass(frozen=True, eq=False)
class BuiltObject:
    """Parts placed in the body frame with their mass properties and summary."""

    info: ObjectInfo
    parts: tuple[Part, ...]
    center_of_mass: np.ndarray
    inertia: np.ndarray


def names() -> list[str]:
    """Names of all registered objects, sorted."""
    return OBJECTS.names()


def default_params(name: str) -> Any:
    """The frozen params dataclass of object `name` with its default values."""
    return OBJECTS.get(name).default_params


def description(name: str) -> str:
    """One-line description of object `name`."""
    return OBJECTS.entry(name).description


def is_mesh_object(name: str) -> bool:
    """Whether object `name` comes from a mesh file (and so from a convex decomposition)."""
    return "mesh" in OBJECTS.entry(name).tags


def _check_params(name: str, params: Any) -> Any:
    """Return `params` (or the defaults) after checking its type fits object `name`."""
    default = default_params(name)
    if params is None:
        return default
    if type(params) is not type(default):
        raise ParameterError(f"params for object {name!r} must be {type(default).__name__}, "
                             f"got {type(params).__name__}")
    return params


@functools.lru_cache(maxsize=64)
def _build(name: str, params: Any) -> BuiltObject:
    shape = OBJECTS.get(name).build(params)
    lo = np.min([p.bounds()[0] for p in shape.parts], axis=0)
    hi = np.max([p.bounds()[1] for p in shape.parts], axis=0)
    axis = (lo[:2] + hi[:2]) / 2 if shape.axis_xy is None else np.asarray(shape.axis_xy)
    shift = np.array([-axis[0], -axis[1], -lo[2]])
    parts = tuple(p.translated(shift) for p in shape.parts)
    if shape.material is not None:
        material = shape.material.transformed(np.eye(3), shift)
    else:
        material = union_moments(parts, solid=False)
    if shape.volume_m3 is not None:
        volume = shape.volume_m3
    elif any(isinstance(p, Sphere) and p.shell_m is not None for p in parts):
        volume = union_moments(parts, solid=True).volume
    else:
        volume = material.volume
    hull = hull_points(parts) if shape.hull is None else shape.hull + shift
    hull_vol = hull_volume(hull)
    inertia = material.inertia(shape.mass_kg)
    info = ObjectInfo(
        name=name,
        mass_kg=float(shape.mass_kg),
        height_m=float(hi[2] - lo[2]),
        radius_m=max(p.max_radius() for p in parts),
        volume_m3=float(volume),
        hull_volume_m3=hull_vol,
        phi_t=float(volume / hull_vol),
        n_parts=len(parts),
        dims=dict(shape.dims),
        geom_names=tuple(f"object_{p.name}" for p in parts),
        center_of_mass_m=tuple(float(x) for x in material.center),
        inertia_kg_m2=tuple(tuple(float(x) for x in row) for row in inertia),
        notes=shape.notes,
        orientation_free=shape.orientation_free,
    )
    return BuiltObject(info, parts, material.center, inertia)


def build(name: str, params: Any = None) -> BuiltObject:
    """Parts, mass properties and summary of object `name` (cached per name and params)."""
    return _build(name, _check_params(name, params))


def clear_build_cache() -> None:
    """Forget built objects (the on-disk decomposition cache is kept)."""
    _build.cache_clear()


def object_info(name: str, params: Any = None) -> ObjectInfo:
    """Summary of object `name` (dimensions, mass, phi_T, parts) without building a scene."""
    return build(name, params).info


def _add_geom(spec: mujoco.MjSpec, body: mujoco.MjsBody, part: Part) -> None:
    """Add the MuJoCo geom (and mesh asset) of one part to `body`."""
    geom = body.add_geom(name=f"object_{part.name}")
    if isinstance(part, (Capsule, Cylinder)):
        geom.type = (mujoco.mjtGeom.mjGEOM_CAPSULE if isinstance(part, Capsule)
                     else mujoco.mjtGeom.mjGEOM_CYLINDER)
        geom.size = [part.radius, 0.0, 0.0]
        geom.fromto = [*part.p0, *part.p1]
    elif isinstance(part, Sphere):
        geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
        geom.size = [part.radius, 0.0, 0.0]
        geom.pos = list(part.center)
    elif isinstance(part, Box):
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = list(part.half)
        geom.pos = list(part.center)
        geom.quat = list(part.quat)
    elif isinstance(part, ConvexMesh):
        mesh_name = f"object_mesh_{part.name}"
        spec.add_mesh(name=mesh_name, uservert=part.vertices.ravel().tolist())
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = mesh_name
    else:
        raise TypeError(f"unsupported part {type(part).__name__}")
    geom.contype = 1
    geom.conaffinity = 1
    geom.condim = 3
    geom.rgba = [0.85, 0.55, 0.25, 1.0]


def add_object(spec: mujoco.MjSpec, name: str, params: Any = None,
               pos: Sequence[float] = (0.0, 0.0, 0.0),
               quat: Sequence[float] = (1.0, 0.0, 0.0, 0.0)) -> ObjectInfo:
    """Add object `name` to `spec.worldbody` as free body `object` at `pos` (m), `quat` (wxyz)."""
    built = build(name, params)
    if spec.body("object") is not None:
        raise ParameterError("the scene already has a body named 'object'")
    body = spec.worldbody.add_body(name="object", pos=list(pos), quat=list(quat))
    body.add_freejoint(name="object_free")
    body.mass = built.info.mass_kg
    body.ipos = built.center_of_mass.tolist()
    i = built.inertia
    body.fullinertia = [i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2]]
    body.explicitinertial = True
    for part in built.parts:
        _add_geom(spec, body, part)
    return built.info

