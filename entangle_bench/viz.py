"""Drawing a scene in one place: the object's solid parts from a compiled model, and a matplotlib 3D view of
filaments, object, contacts and ground. Used by the trial video, the Foxglove recording, the entanglement
figure (`scripts/plot_entanglement.py`) and `entangle-bench objects show`.

`object_geometry` reads the object's collision geoms (sphere, capsule, cylinder, box, ellipsoid, convex mesh)
from MuJoCo as `Part`s with MuJoCo's own size convention (radius, half-length, half-extents, m). `pack` and
`unpack` store them in a state .npz next to the filament curves, so a figure can draw the object without
building a scene.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import trimesh

KIND_COLORS = {
    "filament-object": "tab:red",
    "filament-filament": "tab:blue",
    "filament-self": "tab:purple",
    "filament-ground": "tab:green",
    "object-ground": "tab:gray",
    "other": "black",
}
OBJECT_COLOR = (0.85, 0.55, 0.25)
_GEOM_KINDS = {
    mujoco.mjtGeom.mjGEOM_SPHERE: "sphere",
    mujoco.mjtGeom.mjGEOM_CAPSULE: "capsule",
    mujoco.mjtGeom.mjGEOM_CYLINDER: "cylinder",
    mujoco.mjtGeom.mjGEOM_BOX: "box",
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: "ellipsoid",
    mujoco.mjtGeom.mjGEOM_MESH: "mesh",
}
KINDS = tuple(_GEOM_KINDS.values())


@dataclass(frozen=True)
class Part:
    """One solid part: `kind` (a KINDS name), MuJoCo `size` (3,) in m, pose (`position_m` (3,), `rotation`
    (3, 3) whose columns are the part's axes) and, for meshes, `vertices_m` (V, 3) and `faces` (T, 3) in the
    part's own frame."""

    kind: str
    size: np.ndarray
    position_m: np.ndarray
    rotation: np.ndarray
    vertices_m: np.ndarray
    faces: np.ndarray


def object_geometry(model: mujoco.MjModel, data: mujoco.MjData, is_object_geom: np.ndarray) -> list[Part]:
    """The object's geoms as Parts in world coordinates (m), at the state in `data` (after kinematics)."""
    parts = []
    for g in np.flatnonzero(is_object_geom):
        kind = _GEOM_KINDS[int(model.geom_type[g])]
        vertices, faces = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int32)
        if kind == "mesh":
            mesh = model.geom_dataid[g]
            v0, f0 = model.mesh_vertadr[mesh], model.mesh_faceadr[mesh]
            vertices = model.mesh_vert[v0 : v0 + model.mesh_vertnum[mesh]].astype(float)
            faces = model.mesh_face[f0 : f0 + model.mesh_facenum[mesh]].copy()
        parts.append(Part(kind, model.geom_size[g].copy(), data.geom_xpos[g].copy(),
                          data.geom_xmat[g].reshape(3, 3).copy(), vertices, faces))
    return parts


def post_geometry(model: mujoco.MjModel, data: mujoco.MjData, is_ground_geom: np.ndarray) -> list[Part]:
    """The post an object may stand on (the ground's geoms but the plane) as Parts in world coordinates (m)."""
    return object_geometry(model, data, is_ground_geom & (model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE))


def in_frame(parts: Sequence[Part], position_m: np.ndarray, rotation: np.ndarray) -> list[Part]:
    """Parts re-expressed in the frame with origin `position_m` and axes `rotation` (columns), e.g. a body's."""
    r = np.asarray(rotation, float)
    return [Part(p.kind, p.size, r.T @ (p.position_m - position_m), r.T @ p.rotation, p.vertices_m, p.faces)
            for p in parts]


@functools.lru_cache(maxsize=256)
def _local_surface(kind: str, size: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Coarse triangle surface of a primitive in its own frame (axis z), for drawing."""
    if kind == "sphere":
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=size[0])
    elif kind == "ellipsoid":
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        mesh.apply_scale(size)
    elif kind == "capsule":
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[10, 6])
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=16)
    elif kind == "box":
        mesh = trimesh.creation.box(extents=2 * np.asarray(size))
    else:
        raise ValueError(f"no surface for part kind {kind!r}")
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def surface(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Triangle surface of a part in its frame's coordinates: vertices (N, 3) m and faces (T, 3)."""
    if part.kind == "mesh":
        local, faces = part.vertices_m, part.faces
    else:
        local, faces = _local_surface(part.kind, tuple(float(s) for s in part.size))
    return local @ part.rotation.T + part.position_m, faces


def pack(parts: Sequence[Part]) -> dict[str, np.ndarray]:
    """Parts as flat arrays (keys `object_*`) for an .npz."""
    return {
        "object_kinds": np.array([p.kind for p in parts], dtype="U9"),
        "object_sizes": np.array([p.size for p in parts], dtype=float).reshape(-1, 3),
        "object_positions_m": np.array([p.position_m for p in parts], dtype=float).reshape(-1, 3),
        "object_rotations": np.array([p.rotation for p in parts], dtype=float).reshape(-1, 3, 3),
        "object_vertices_m": np.concatenate([np.zeros((0, 3))] + [p.vertices_m for p in parts]),
        "object_vertex_counts": np.array([len(p.vertices_m) for p in parts], dtype=np.int64),
        "object_faces": np.concatenate([np.zeros((0, 3), np.int32)] + [p.faces for p in parts]).astype(np.int32),
        "object_face_counts": np.array([len(p.faces) for p in parts], dtype=np.int64),
    }


def unpack(arrays: Mapping[str, Any]) -> list[Part]:
    """Parts stored by `pack` (an empty list when the arrays hold none, e.g. an older state file)."""
    if "object_kinds" not in arrays:
        return []
    vertices = np.split(arrays["object_vertices_m"], np.cumsum(arrays["object_vertex_counts"])[:-1])
    faces = np.split(arrays["object_faces"], np.cumsum(arrays["object_face_counts"])[:-1])
    return [Part(str(k), s, p, r, v, f) for k, s, p, r, v, f in zip(
        arrays["object_kinds"], arrays["object_sizes"], arrays["object_positions_m"],
        arrays["object_rotations"], vertices, faces)]


def draw_scene(
    ax: Any,
    curves_m: Sequence[np.ndarray] = (),
    parts: Sequence[Part] = (),
    contacts: tuple[np.ndarray, np.ndarray] | None = None,
    ground: bool = True,
    curve_color: Any = "0.25",
    part_colors: Sequence[Any] | None = None,
    object_alpha: float = 0.6,
    scale: float = 1e3,
) -> np.ndarray:
    """Draw filaments (lines), object parts (surfaces, one color or `part_colors`), contacts (points colored
    by kind) and the ground (z = 0) onto a matplotlib 3D axis, in m times `scale` (mm by default); return the
    drawn points."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # matplotlib only where something is drawn

    points = [np.zeros((0, 3))]
    for curve in curves_m:
        ax.plot(*(scale * np.asarray(curve)).T, color=curve_color, linewidth=1.0)
        points.append(scale * np.asarray(curve))
    triangles, colors = [], []
    for k, part in enumerate(parts):
        vertices, faces = surface(part)
        triangles.append(scale * vertices[faces])
        colors += [OBJECT_COLOR if part_colors is None else part_colors[k]] * len(faces)
    if triangles:
        every = np.concatenate(triangles)
        edges = "none" if part_colors is None else "k"
        ax.add_collection3d(Poly3DCollection(every, facecolors=colors, edgecolor=edges, linewidths=0.1,
                                             alpha=object_alpha))
        points.append(every.reshape(-1, 3))
    if contacts is not None and len(contacts[0]):
        contact_points, kinds = scale * np.asarray(contacts[0]), np.asarray(contacts[1])
        for kind, color in KIND_COLORS.items():
            chosen = kinds == kind
            if chosen.any():
                ax.scatter(*contact_points[chosen].T, color=color, s=8, depthshade=False, label=kind)
        points.append(contact_points)
    drawn = np.concatenate(points)
    if ground and len(drawn):
        lo, hi = drawn[:, :2].min(axis=0), drawn[:, :2].max(axis=0)
        pad = 0.1 * float(np.max(hi - lo)) + 1e-9
        (x0, y0), (x1, y1) = lo - pad, hi + pad
        quad = [[(x0, y0, 0.0), (x1, y0, 0.0), (x1, y1, 0.0), (x0, y1, 0.0)]]
        ax.add_collection3d(Poly3DCollection(quad, facecolor="0.85", edgecolor="0.6", alpha=0.5))
    return drawn


def set_equal_axes(ax: Any, points: np.ndarray, floor: float | None = None, unit: str = "mm") -> None:
    """Equal scale on x, y, z around `points` (optionally not below z = `floor`), axes labelled in `unit`."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    center, half = 0.5 * (lo + hi), 0.5 * max(float((hi - lo).max()), 1e-9)
    z0 = center[2] - half if floor is None else max(floor, center[2] - half)
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(z0, z0 + 2 * half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_zlabel(f"z ({unit})")
