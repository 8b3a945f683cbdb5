"""Mesh objects: load, repair and check a mesh (metres), decompose it into convex parts with CoACD
(Wei et al., "Approximate convex decomposition for 3D meshes with collision-aware concavity and tree
search", SIGGRAPH 2022) and cache the parts keyed by the mesh file and the settings.

The cache key is the SHA-256 of a format tag, the mesh file's bytes (line endings normalized), the scale
and the CoACD settings: nothing a library computes, so it is the same on every machine and install. (The
first key hashed the loaded and repaired mesh; trimesh's `split` returns faces in an order that follows
numpy's unstable sort, which differs between numpy versions and CPUs, so a fresh install could miss the
committed cache and spend half a minute in CoACD.) Bump `_CACHE_FORMAT` when loading or repair changes
what CoACD is given. Lookup and write folders: `entangle_bench.resources`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata
import json
import math
import os
import sys
import threading
import time
import typing
import zipfile
from pathlib import Path

import coacd
import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError
from tqdm import tqdm

from entangle_bench import resources
from entangle_bench.atomic import atomic_save_npz
from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import MeshError, ParameterError
from entangle_bench.objects.geometry import ConvexMesh, Shape, mesh_moments

ASSETS_DIR = resources.assets_dir()
MIN_EXTENT_M = 0.005  # smallest plausible graspable object (largest side, m)
MAX_EXTENT_M = 1.0  # largest plausible graspable object (largest side, m)
_CACHE_FORMAT = "entangle-bench coacd cache v2"


@dataclasses.dataclass(frozen=True)
class CoacdSettings:
    """CoACD parameters (see coacd.run_coacd); defaults favour speed over tight fits.

    `threshold` is the concavity tolerance (fraction of the mesh size), `max_convex_hull` caps the
    number of parts, `max_ch_vertex` the vertices per part (hulls are decimated to it).
    """

    threshold: float = 0.05
    max_convex_hull: int = 48
    preprocess_resolution: int = 50
    resolution: int = 2000
    mcts_nodes: int = 15
    mcts_iterations: int = 60
    mcts_max_depth: int = 2
    max_ch_vertex: int = 64
    seed: int = 0

    def __post_init__(self):
        for f in dataclasses.fields(self):
            if f.type in ("int", int) and not isinstance(getattr(self, f.name), int):
                raise ParameterError(f"coacd.{f.name} must be an integer")
        check_range("coacd.threshold", self.threshold, 0.01, 1.0)
        check_range("coacd.max_convex_hull", self.max_convex_hull, 1, 256)
        check_range("coacd.preprocess_resolution", self.preprocess_resolution, 10, 200)
        check_range("coacd.resolution", self.resolution, 100, 20000)
        check_range("coacd.mcts_nodes", self.mcts_nodes, 1, 100)
        check_range("coacd.mcts_iterations", self.mcts_iterations, 10, 1000)
        check_range("coacd.mcts_max_depth", self.mcts_max_depth, 1, 10)
        check_range("coacd.max_ch_vertex", self.max_ch_vertex, 8, 1024)
        check_range("coacd.seed", self.seed, 0, None)

    def kwargs(self) -> dict[str, typing.Any]:
        """Keyword arguments for coacd.run_coacd."""
        out = dataclasses.asdict(self)
        out.update(decimate=True, preprocess_mode="auto", merge=True)
        return out


@dataclasses.dataclass(frozen=True)
class MeshObjectParams:
    """An object from a mesh file; relative `mesh_file` paths are under assets/.

    Mass: `mass_kg` if given, else `density_kg_m3` x mesh volume. `rest_pose` "stable" turns the
    mesh onto the hull face that puts its centre of mass lowest (with the centre of mass over the
    face); "as_is" keeps the file's orientation. `cache_dir` None means the committed caches, then the
    user cache (`entangle_bench.resources`).
    """

    mesh_file: str
    mass_kg: float | None = None
    density_kg_m3: float = 1000.0
    scale: float = 1.0
    rest_pose: typing.Literal["stable", "as_is"] = "stable"
    coacd: CoacdSettings = CoacdSettings()
    cache_dir: str | None = None

    def __post_init__(self):
        if not isinstance(self.mesh_file, str) or not self.mesh_file:
            raise ParameterError("mesh_file must be a non-empty path")
        if self.mass_kg is not None:
            check_range("mass_kg", self.mass_kg, 0.0, 100.0, low_open=True)
        check_range("density_kg_m3", self.density_kg_m3, 1.0, 30000.0)
        check_range("scale", self.scale, 0.0, None, low_open=True)
        check_choice("rest_pose", self.rest_pose, ["stable", "as_is"])
        if not isinstance(self.coacd, CoacdSettings):
            raise ParameterError("coacd must be a CoacdSettings")

    @property
    def path(self) -> Path:
        """Absolute path of the mesh file."""
        p = Path(self.mesh_file)
        return p if p.is_absolute() else ASSETS_DIR / p

    @property
    def cache_path(self) -> Path | None:
        """Folder of the decomposition cache; None for the default folders."""
        return None if self.cache_dir is None else Path(self.cache_dir)


def check_scale(mesh: trimesh.Trimesh, source: str) -> None:
    """Raise MeshError unless the mesh's largest side is a plausible object size in metres."""
    extent = float(np.max(mesh.extents))
    if extent > MAX_EXTENT_M:
        raise MeshError(
            f"mesh {source} is {extent:.4g} m across, implausibly large for a graspable object "
            f"(allowed {MIN_EXTENT_M:g}-{MAX_EXTENT_M:g} m); meshes must be in metres - if the "
            f"file is in millimetres, scale it by 0.001")
    if extent < MIN_EXTENT_M:
        raise MeshError(
            f"mesh {source} is {extent:.4g} m across, implausibly small for a graspable object "
            f"(allowed {MIN_EXTENT_M:g}-{MAX_EXTENT_M:g} m); meshes must be in metres - check the "
            f"file's units and the scale")


def repair_mesh(mesh: trimesh.Trimesh, source: str) -> tuple[trimesh.Trimesh, list[str]]:
    """Return a watertight version of `mesh` and notes on what was changed.

    Keeps the closed, outward bodies; drops flat fragments (|volume| < 0.1 % of the largest body),
    open pieces and inward-facing closed shells (cavities, which CoACD would fill anyway). Holes
    are not filled. Raises MeshError when no closed body remains.
    """
    if mesh.is_volume:
        return mesh, []
    notes: list[str] = []
    bodies = mesh.split(only_watertight=False, repair=False)  # repair=True needs networkx
    with np.errstate(invalid="ignore", divide="ignore"):  # flat fragments have zero volume
        volumes = [float(b.volume) for b in bodies]
    largest = max(abs(v) for v in volumes)
    kept: list[trimesh.Trimesh] = []
    fragments = open_pieces = cavities = 0
    for body, volume in zip(bodies, volumes, strict=True):
        if not body.is_watertight:
            open_pieces += 1
        elif abs(volume) < 1e-3 * largest:
            fragments += 1
        elif volume < 0:
            cavities += 1
        else:
            kept.append(body)
    if fragments:
        notes.append(f"dropped {fragments} flat fragment(s)")
    if cavities:
        notes.append(f"dropped {cavities} inward-facing shell(s) (cavities)")
    if open_pieces:
        notes.append(f"dropped {open_pieces} open piece(s)")
    if not kept:
        open_edges = int(np.sum(np.bincount(mesh.edges_unique_inverse) == 1))
        raise MeshError(
            f"mesh {source} is not watertight and could not be repaired ({len(bodies)} piece(s), "
            f"{open_edges} open edge(s)); close it in a mesh editor")
    repaired = kept[0] if len(kept) == 1 else trimesh.util.concatenate(kept)
    if not repaired.is_volume:
        raise MeshError(f"mesh {source}: the repaired mesh is still not a closed volume "
                        f"(consistent winding: {repaired.is_winding_consistent}); fix it in a "
                        f"mesh editor")
    return repaired, notes


def load_mesh(path: str | os.PathLike, scale: float = 1.0) -> tuple[trimesh.Trimesh, list[str]]:
    """Load, repair and check a mesh file; return it (m, after `scale`) and notes on repairs."""
    path = Path(path)
    if not path.is_file():
        raise MeshError(f"mesh file not found: {path}")
    try:
        loaded = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise MeshError(f"cannot read mesh file {path}: {exc}") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"mesh file {path} is empty (no triangles)")
    mesh = loaded.copy()
    if scale != 1.0:
        mesh.apply_scale(scale)
    check_scale(mesh, str(path))
    return repair_mesh(mesh, str(path))


@dataclasses.dataclass(frozen=True)
class Decomposition:
    """Convex parts of a mesh as (vertices (m), triangle faces) pairs, the cache file, whether
    it was a cache hit and how long CoACD took (s)."""

    parts: tuple[tuple[np.ndarray, np.ndarray], ...]
    key: str
    path: Path
    from_cache: bool
    seconds: float


def file_digest(path: str | os.PathLike, scale: float = 1.0) -> str:
    """SHA-256 of a mesh file's bytes (CRLF read as LF) and the scale: the source of a decomposition."""
    data = Path(path).read_bytes().replace(b"\r\n", b"\n")
    return hashlib.sha256(data + f"\nscale={float(scale)!r}".encode()).hexdigest()


def mesh_digest(mesh: trimesh.Trimesh) -> str:
    """SHA-256 of an in-memory mesh's arrays: a source for meshes without a file (valid on this install only)."""
    h = hashlib.sha256(np.ascontiguousarray(mesh.vertices, "<f8").tobytes())
    h.update(np.ascontiguousarray(mesh.faces, "<i8").tobytes())
    return h.hexdigest()


def cache_key(source: str, settings: CoacdSettings) -> str:
    """SHA-256 of the cache format, the source digest (`file_digest`) and the CoACD settings."""
    h = hashlib.sha256(_CACHE_FORMAT.encode())
    h.update(source.encode())
    h.update(json.dumps(dataclasses.asdict(settings), sort_keys=True).encode())
    return h.hexdigest()


def _read_cache(path: Path) -> tuple[tuple[tuple[np.ndarray, np.ndarray], ...], float] | None:
    """Parts and decomposition time stored in a cache file, or None when absent or unreadable."""
    if not path.is_file():
        return None
    try:
        with np.load(path) as data:
            verts, faces = data["vertices"], data["faces"]
            v_off, f_off = data["vertex_offsets"], data["face_offsets"]
            seconds = float(data["seconds"])
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None
    parts = tuple((verts[v_off[i]:v_off[i + 1]], faces[f_off[i]:f_off[i + 1]])
                  for i in range(len(v_off) - 1))
    return parts, seconds


def _write_cache(path: Path, parts: typing.Sequence[tuple[np.ndarray, np.ndarray]],
                 seconds: float, settings: CoacdSettings) -> None:
    """Write parts atomically (temporary file in the same folder, then rename)."""
    atomic_save_npz(path, vertices=np.concatenate([v for v, _ in parts]).astype("<f8"),
                    faces=np.concatenate([f for _, f in parts]).astype("<i4"),
                    vertex_offsets=np.cumsum([0] + [len(v) for v, _ in parts]),
                    face_offsets=np.cumsum([0] + [len(f) for _, f in parts]),
                    seconds=np.float64(seconds),
                    settings=json.dumps(dataclasses.asdict(settings)),
                    coacd_version=importlib.metadata.version("coacd"))


def _run_with_ticker(label: str, work: typing.Callable[[], typing.Any]) -> typing.Any:
    """Run `work()` while a tqdm line on stderr shows the elapsed time (CoACD releases the GIL)."""
    bar = tqdm(total=None, desc=f"coacd {label}", file=sys.stderr,
               bar_format="{desc}: {elapsed} elapsed")
    done = threading.Event()

    def tick() -> None:
        while not done.wait(1.0):
            bar.refresh()

    thread = threading.Thread(target=tick, daemon=True)
    thread.start()
    try:
        return work()
    finally:
        done.set()
        thread.join()
        bar.close()


def decompose(mesh: trimesh.Trimesh, settings: CoacdSettings = CoacdSettings(),
              cache_dir: str | os.PathLike | None = None, label: str = "mesh",
              progress: bool = False, force: bool = False, source: str | None = None) -> Decomposition:
    """Convex parts of `mesh` from the cache or, on a miss (or `force`), from CoACD.

    `source` is the digest the cache key is made from (`file_digest` of the mesh file; default
    `mesh_digest(mesh)`). `cache_dir` None searches `resources.coacd_cache_dirs()` and writes to
    `resources.coacd_write_dir()`. The cache file is written only after CoACD finished, atomically, so an
    interrupted run leaves nothing behind. `progress` shows the elapsed time on stderr while CoACD runs.
    """
    key = cache_key(source or mesh_digest(mesh), settings)
    name = f"{label}-{key[:16]}.npz"
    folders = resources.coacd_cache_dirs() if cache_dir is None else (Path(cache_dir),)
    for folder in () if force else folders:
        cached = _read_cache(folder / name)
        if cached is not None:
            return Decomposition(cached[0], key, folder / name, True, cached[1])
    path = (resources.coacd_write_dir() if cache_dir is None else Path(cache_dir)) / name
    coacd.set_log_level("error")
    coacd_mesh = coacd.Mesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))
    start = time.perf_counter()
    if progress:
        raw = _run_with_ticker(label, lambda: coacd.run_coacd(coacd_mesh, **settings.kwargs()))
    else:
        raw = coacd.run_coacd(coacd_mesh, **settings.kwargs())
    seconds = time.perf_counter() - start
    parts = []
    for verts, faces in raw:
        v = np.asarray(verts, float)
        try:
            if len(v) >= 4 and ConvexHull(v).volume > 0:
                parts.append((v, np.asarray(faces, np.int32)))
        except QhullError:
            continue  # a flat sliver: no volume, nothing to collide with
    if not parts:
        raise MeshError(f"CoACD returned no solid parts for {label}")
    _write_cache(path, parts, seconds, settings)
    return Decomposition(tuple(parts), key, path, False, seconds)


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrix turning unit vector `a` onto unit vector `b` (Rodrigues)."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if c < -1 + 1e-12:
        axis = np.cross(a, [1.0, 0.0, 0.0])
        if np.linalg.norm(axis) < 1e-6:
            axis = np.cross(a, [0.0, 1.0, 0.0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


def stable_rotation(vertices: np.ndarray, center_of_mass: np.ndarray) -> np.ndarray:
    """Rotation putting the body on the hull face that holds its centre of mass lowest.

    Only faces over which the centre of mass projects at least 5 % of the body size inside the
    face's edges count (a margin against tipping); with none, the face with the largest margin.
    """
    hull = ConvexHull(vertices)
    size = float(np.max(np.ptp(vertices, axis=0)))
    planes = np.round(hull.equations / [1, 1, 1, size], 6)
    best: tuple[float, float, np.ndarray] | None = None  # (score, margin, normal)
    for plane in np.unique(planes, axis=0):
        members = np.all(planes == plane, axis=1)
        normal = hull.equations[members][0, :3]
        offset = hull.equations[members][0, 3]
        height = -(normal @ center_of_mass + offset)
        pts = vertices[np.unique(hull.simplices[members])]
        basis = np.linalg.svd(np.eye(3) - np.outer(normal, normal))[0][:, :2]
        try:
            face = ConvexHull(pts @ basis)
        except QhullError:
            continue
        foot = center_of_mass @ basis
        margin = float(-np.max(face.equations[:, :2] @ foot + face.equations[:, 2]))
        ok = margin >= 0.05 * size
        score = height if ok else math.inf
        if best is None or (score, -margin) < (best[0], -best[1]):
            best = (score, margin, normal)
    assert best is not None
    return _rotation_between(best[2], np.array([0.0, 0.0, -1.0]))


def decompose_object(p: MeshObjectParams, mesh: trimesh.Trimesh, progress: bool = False,
                     force: bool = False) -> Decomposition:
    """Decomposition of the loaded mesh of `p`, cached under the digest of its file and scale."""
    return decompose(mesh, p.coacd, p.cache_path, label=p.path.stem, progress=progress, force=force,
                     source=file_digest(p.path, p.scale))


def build_mesh_object(p: MeshObjectParams) -> Shape:
    """Shape of a mesh object: CoACD parts (cached) in its rest pose, mass from the source mesh."""
    mesh, notes = load_mesh(p.path, p.scale)
    decomposition = decompose_object(p, mesh)
    moments = mesh_moments(mesh.vertices, mesh.faces)
    rot = np.eye(3)
    if p.rest_pose == "stable":
        rot = stable_rotation(np.asarray(mesh.vertices), moments.center)
    parts = tuple(ConvexMesh(f"part{i:02d}", v @ rot.T)
                  for i, (v, _) in enumerate(decomposition.parts))
    hull = np.asarray(mesh.vertices) @ rot.T
    extent = np.ptp(hull, axis=0)
    mass = p.mass_kg if p.mass_kg is not None else p.density_kg_m3 * moments.volume
    dims = {"extent_x_m": float(extent[0]), "extent_y_m": float(extent[1]),
            "extent_z_m": float(extent[2])}
    return Shape(parts, mass, dims, material=moments.transformed(rot, np.zeros(3)),
                 volume_m3=moments.volume, hull=hull, notes=tuple(notes))
