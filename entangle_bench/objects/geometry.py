"""Solid parts of an object (capsule, cylinder, sphere, box, convex mesh) and their union's volume,
mass moments and convex hull, all in metres in the object's body frame.

Mass properties of a union of overlapping parts: the exact analytic moments of every part are summed
and the overlap counted twice is removed by Monte Carlo. A point x sampled uniformly in part i that
lies in n(x) parts carries the surplus weight (V_i / N)(1 - 1/n(x)), because
integral over the union of f = sum_i integral over part i of f / n (inclusion by multiplicity). Only
points in overlaps contribute, so parts that do not overlap are exact and the sampling error scales
with the (small) overlap volume, not with the whole object.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from entangle_bench.errors import ParameterError

_SPHERE_HULL_POINTS = 400
_RIM_POINTS = 128


@dataclasses.dataclass(frozen=True)
class Moments:
    """Volume moments of a solid: volume (m^3), first moment (m^4), S = int x x^T dV (m^5)."""

    volume: float
    first: np.ndarray
    second: np.ndarray

    def __add__(self, other: Moments) -> Moments:
        return Moments(self.volume + other.volume, self.first + other.first,
                       self.second + other.second)

    def __sub__(self, other: Moments) -> Moments:
        return Moments(self.volume - other.volume, self.first - other.first,
                       self.second - other.second)

    @staticmethod
    def zero() -> Moments:
        """Return the moments of nothing."""
        return Moments(0.0, np.zeros(3), np.zeros((3, 3)))

    def transformed(self, rotation: np.ndarray, offset: Sequence[float],
                    scale: float = 1.0) -> Moments:
        """Return the moments of the solid mapped by x -> scale * R x + offset."""
        t = np.asarray(offset, float)
        r = np.asarray(rotation, float)
        vol = self.volume * scale**3
        first = scale**4 * (r @ self.first)
        second = scale**5 * (r @ self.second @ r.T)
        second = second + np.outer(first, t) + np.outer(t, first) + vol * np.outer(t, t)
        return Moments(vol, first + vol * t, second)

    @property
    def center(self) -> np.ndarray:
        """Centroid (m)."""
        return self.first / self.volume

    def inertia(self, mass_kg: float) -> np.ndarray:
        """Inertia tensor (kg m^2) about the centroid of a uniform solid of mass `mass_kg`."""
        c = self.center
        s_c = self.second / self.volume - np.outer(c, c)
        return mass_kg * (np.trace(s_c) * np.eye(3) - s_c)


def _frame(axis: np.ndarray) -> np.ndarray:
    """Return a rotation matrix whose third column is the unit vector `axis`."""
    a = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(a, helper)
    u /= np.linalg.norm(u)
    return np.column_stack([u, np.cross(a, u), a])


@functools.lru_cache(maxsize=8)
def _fibonacci_sphere(n: int) -> np.ndarray:
    """`n` nearly uniform points (Fibonacci lattice) pushed out so their hull has the unit ball's
    volume: hulls of sphere-swept parts then come out nearly exact instead of ~1.5 % low."""
    z = np.linspace(1.0, -1.0, n)
    phi = np.arange(n) * math.pi * (3.0 - math.sqrt(5.0))
    rho = np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    pts = np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])
    return pts * (4.0 / 3.0 * math.pi / ConvexHull(pts).volume) ** (1.0 / 3.0)


def _local_moments(volume: float, first_local: np.ndarray, second_local: np.ndarray,
                   rotation: np.ndarray, origin: np.ndarray) -> Moments:
    """Map moments given in a part's local frame to the body frame."""
    return Moments(volume, np.asarray(first_local, float),
                   np.asarray(second_local, float)).transformed(rotation, origin)


def quat_to_matrix(quat: Sequence[float]) -> np.ndarray:
    """Rotation matrix of the unit quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(quat, float) / np.linalg.norm(quat)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def mesh_moments(vertices: np.ndarray, faces: np.ndarray) -> Moments:
    """Exact volume moments of a closed, outward-oriented triangle mesh (signed tetrahedra)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    o = v.mean(axis=0)
    a, b, c = v[f[:, 0]] - o, v[f[:, 1]] - o, v[f[:, 2]] - o
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    s = a + b + c
    # tetrahedron (0, a, b, c): volume det/6, int x = det s / 24,
    # int x x^T = det (sum of v v^T over a, b, c + s s^T) / 120
    second = (np.einsum("n,ni,nj->ij", det, s, s) + np.einsum("n,ni,nj->ij", det, a, a)
              + np.einsum("n,ni,nj->ij", det, b, b) + np.einsum("n,ni,nj->ij", det, c, c)) / 120.0
    first = (det[:, None] * s).sum(0) / 24.0
    return Moments(float(det.sum() / 6.0), first, second).transformed(np.eye(3), o)


@dataclasses.dataclass(frozen=True)
class Capsule:
    """Capsule: segment p0-p1 (m) swept by a sphere of `radius` (m)."""

    name: str
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    radius: float

    def __post_init__(self):
        if not self.radius > 0 or np.linalg.norm(np.subtract(self.p1, self.p0)) <= 0:
            raise ParameterError(f"capsule {self.name!r} needs radius > 0 and p0 != p1")

    @property
    def _axis(self) -> tuple[np.ndarray, float, np.ndarray]:
        a = np.subtract(self.p1, self.p0).astype(float)
        length = float(np.linalg.norm(a))
        return np.asarray(self.p0, float), length, _frame(a)

    def volume(self, solid: bool = True) -> float:
        """Volume (m^3)."""
        r, h = self.radius, self._axis[1]
        return math.pi * r * r * h + 4.0 / 3.0 * math.pi * r**3

    def moments(self, solid: bool = True) -> Moments:
        """Exact volume moments about the body origin."""
        p0, h, rot = self._axis
        r = self.radius
        v_cyl = math.pi * r * r * h
        v_half = 2.0 / 3.0 * math.pi * r**3
        # local frame: axis z from 0 to h; cylinder plus one hemisphere at each end
        xx = v_cyl * r * r / 4 + 2 * v_half * r * r / 5
        zz_cyl = v_cyl * h * h / 3
        zz_top = v_half * (h * h + 2 * h * 3 * r / 8 + r * r / 5)  # dome z = h + z', z' in [0, r]
        zz_bottom = v_half * r * r / 5  # dome z = -z', z' in [0, r]
        vol = v_cyl + 2 * v_half
        first = np.array([0.0, 0.0, v_cyl * h / 2 + v_half * h])  # dome offsets +-3r/8 cancel
        second = np.diag([xx, xx, zz_cyl + zz_top + zz_bottom])
        return _local_moments(vol, first, second, rot, p0)

    def contains(self, pts: np.ndarray, solid: bool = True) -> np.ndarray:
        """Whether each point (n, 3) lies inside."""
        p0 = np.asarray(self.p0, float)
        a = np.subtract(self.p1, p0)
        h2 = float(a @ a)
        d = pts - p0
        t = np.clip(d @ a, 0.0, h2) / h2
        e = d - t[:, None] * a
        return np.einsum("ij,ij->i", e, e) <= self.radius**2

    def sample(self, n: int, rng: np.random.Generator, solid: bool = True) -> np.ndarray:
        """`n` points uniformly distributed inside (rejection in the local bounding box)."""
        p0, h, rot = self._axis
        r = self.radius
        out: list[np.ndarray] = []
        count = 0
        while count < n:
            q = rng.uniform([-r, -r, -r], [r, r, h + r], size=(2 * n, 3))
            zc = np.clip(q[:, 2], 0.0, h)
            keep = q[:, 0] ** 2 + q[:, 1] ** 2 + (q[:, 2] - zc) ** 2 <= r * r
            out.append(q[keep])
            count += int(keep.sum())
        return np.concatenate(out)[:n] @ rot.T + p0

    def hull_points(self) -> np.ndarray:
        """Surface points whose convex hull approximates the part's (two end spheres)."""
        s = _fibonacci_sphere(_SPHERE_HULL_POINTS // 2) * self.radius
        return np.concatenate([s + self.p0, s + self.p1])

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds [[xmin, ymin, zmin], [xmax, ymax, zmax]] (m)."""
        ends = np.array([self.p0, self.p1], float)
        return np.array([ends.min(0) - self.radius, ends.max(0) + self.radius])

    def max_radius(self) -> float:
        """Largest horizontal distance (m) of the part from the body's z axis."""
        return max(math.hypot(p[0], p[1]) for p in (self.p0, self.p1)) + self.radius

    def translated(self, t: np.ndarray) -> Capsule:
        """Copy shifted by `t` (m)."""
        return dataclasses.replace(self, p0=tuple(np.add(self.p0, t)), p1=tuple(np.add(self.p1, t)))


@dataclasses.dataclass(frozen=True)
class Cylinder:
    """Solid circular cylinder with flat ends from p0 to p1 (m) and `radius` (m)."""

    name: str
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    radius: float

    def __post_init__(self):
        if not self.radius > 0 or np.linalg.norm(np.subtract(self.p1, self.p0)) <= 0:
            raise ParameterError(f"cylinder {self.name!r} needs radius > 0 and p0 != p1")

    @property
    def _axis(self) -> tuple[np.ndarray, float, np.ndarray]:
        a = np.subtract(self.p1, self.p0).astype(float)
        return np.asarray(self.p0, float), float(np.linalg.norm(a)), _frame(a)

    def volume(self, solid: bool = True) -> float:
        """Volume (m^3)."""
        return math.pi * self.radius**2 * self._axis[1]

    def moments(self, solid: bool = True) -> Moments:
        """Exact volume moments about the body origin."""
        p0, h, rot = self._axis
        vol = self.volume()
        xx = vol * self.radius**2 / 4
        return _local_moments(vol, np.array([0.0, 0.0, vol * h / 2]),
                              np.diag([xx, xx, vol * h * h / 3]), rot, p0)

    def contains(self, pts: np.ndarray, solid: bool = True) -> np.ndarray:
        """Whether each point (n, 3) lies inside."""
        p0, h, rot = self._axis
        a = rot[:, 2]
        d = pts - p0
        t = d @ a
        return (t >= 0) & (t <= h) & (np.sum((d - t[:, None] * a) ** 2, axis=1) <= self.radius**2)

    def sample(self, n: int, rng: np.random.Generator, solid: bool = True) -> np.ndarray:
        """`n` points uniformly distributed inside."""
        p0, h, rot = self._axis
        rad = self.radius * np.sqrt(rng.uniform(size=n))
        ang = rng.uniform(0, 2 * math.pi, size=n)
        q = np.column_stack([rad * np.cos(ang), rad * np.sin(ang), rng.uniform(0, h, size=n)])
        return q @ rot.T + p0

    def _rims(self, scale: float = 1.0) -> np.ndarray:
        p0, _, rot = self._axis
        ang = np.linspace(0, 2 * math.pi, _RIM_POINTS, endpoint=False)
        r = self.radius * scale
        circle = r * (np.outer(np.cos(ang), rot[:, 0]) + np.outer(np.sin(ang), rot[:, 1]))
        return np.concatenate([circle + p0, circle + np.asarray(self.p1, float)])

    def hull_points(self) -> np.ndarray:
        """Points on both end rims, pushed out so that the polygon has the circle's area."""
        n = _RIM_POINTS
        return self._rims(math.sqrt(2 * math.pi / (n * math.sin(2 * math.pi / n))))

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds (m), exact."""
        a = self._axis[2][:, 2]
        ext = self.radius * np.sqrt(np.clip(1.0 - a * a, 0.0, None))
        ends = np.array([self.p0, self.p1], float)
        return np.array([ends.min(0) - ext, ends.max(0) + ext])

    def max_radius(self) -> float:
        """Largest horizontal distance (m) of the part from the body's z axis (rim samples)."""
        return float(np.max(np.hypot(*self._rims()[:, :2].T)))

    def translated(self, t: np.ndarray) -> Cylinder:
        """Copy shifted by `t` (m)."""
        return dataclasses.replace(self, p0=tuple(np.add(self.p0, t)), p1=tuple(np.add(self.p1, t)))


@dataclasses.dataclass(frozen=True)
class Sphere:
    """Sphere of `radius` (m); with `shell_m` set its mass sits in a shell of that wall thickness.

    Collision and the object's volume always use the full ball; the shell only changes mass moments.
    """

    name: str
    center: tuple[float, float, float]
    radius: float
    shell_m: float | None = None

    def __post_init__(self):
        if not self.radius > 0:
            raise ParameterError(f"sphere {self.name!r} needs radius > 0")
        if self.shell_m is not None and not 0 < self.shell_m <= self.radius:
            raise ParameterError(f"sphere {self.name!r}: shell_m must be in (0, radius]")

    @property
    def _inner(self) -> float:
        return 0.0 if self.shell_m is None else self.radius - self.shell_m

    def volume(self, solid: bool = True) -> float:
        """Volume (m^3) of the ball (solid) or of the mass-carrying shell."""
        inner = 0.0 if solid else self._inner
        return 4.0 / 3.0 * math.pi * (self.radius**3 - inner**3)

    def moments(self, solid: bool = True) -> Moments:
        """Exact volume moments about the body origin."""
        inner = 0.0 if solid else self._inner
        vol = self.volume(solid)
        xx = 4.0 * math.pi / 15.0 * (self.radius**5 - inner**5)
        return _local_moments(vol, np.zeros(3), xx * np.eye(3), np.eye(3),
                              np.asarray(self.center, float))

    def contains(self, pts: np.ndarray, solid: bool = True) -> np.ndarray:
        """Whether each point (n, 3) lies inside (the ball, or the shell when not `solid`)."""
        d2 = np.sum((pts - np.asarray(self.center)) ** 2, axis=1)
        inner = 0.0 if solid else self._inner
        return (d2 <= self.radius**2) & (d2 >= inner**2)

    def sample(self, n: int, rng: np.random.Generator, solid: bool = True) -> np.ndarray:
        """`n` points uniformly distributed in the ball (or shell)."""
        inner = 0.0 if solid else self._inner
        d = rng.normal(size=(n, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        r = np.cbrt(inner**3 + rng.uniform(size=n) * (self.radius**3 - inner**3))
        return d * r[:, None] + np.asarray(self.center)

    def hull_points(self) -> np.ndarray:
        """Surface points whose hull approximates the ball."""
        return _fibonacci_sphere(_SPHERE_HULL_POINTS) * self.radius + np.asarray(self.center)

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds (m), exact."""
        c = np.asarray(self.center, float)
        return np.array([c - self.radius, c + self.radius])

    def max_radius(self) -> float:
        """Largest horizontal distance (m) from the body's z axis."""
        return math.hypot(self.center[0], self.center[1]) + self.radius

    def translated(self, t: np.ndarray) -> Sphere:
        """Copy shifted by `t` (m)."""
        return dataclasses.replace(self, center=tuple(np.add(self.center, t)))


@dataclasses.dataclass(frozen=True)
class Box:
    """Box with half sizes `half` (m) at `center`, rotated by quaternion `quat` (w, x, y, z)."""

    name: str
    center: tuple[float, float, float]
    half: tuple[float, float, float]
    quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)

    def __post_init__(self):
        if min(self.half) <= 0:
            raise ParameterError(f"box {self.name!r} needs positive half sizes")

    def volume(self, solid: bool = True) -> float:
        """Volume (m^3)."""
        return 8.0 * float(np.prod(self.half))

    def moments(self, solid: bool = True) -> Moments:
        """Exact volume moments about the body origin."""
        vol = self.volume()
        return _local_moments(vol, np.zeros(3), np.diag(vol * np.square(self.half) / 3),
                              quat_to_matrix(self.quat), np.asarray(self.center, float))

    def contains(self, pts: np.ndarray, solid: bool = True) -> np.ndarray:
        """Whether each point (n, 3) lies inside."""
        local = (pts - np.asarray(self.center)) @ quat_to_matrix(self.quat)
        return np.all(np.abs(local) <= np.asarray(self.half), axis=1)

    def sample(self, n: int, rng: np.random.Generator, solid: bool = True) -> np.ndarray:
        """`n` points uniformly distributed inside."""
        h = np.asarray(self.half)
        local = rng.uniform(-h, h, size=(n, 3))
        return local @ quat_to_matrix(self.quat).T + np.asarray(self.center)

    def hull_points(self) -> np.ndarray:
        """The eight corners (m)."""
        signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        local = signs * np.asarray(self.half)
        return local @ quat_to_matrix(self.quat).T + np.asarray(self.center)

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds (m), exact."""
        c = self.hull_points()
        return np.array([c.min(0), c.max(0)])

    def max_radius(self) -> float:
        """Largest horizontal distance (m) from the body's z axis, exact."""
        return float(np.max(np.hypot(*self.hull_points()[:, :2].T)))

    def translated(self, t: np.ndarray) -> Box:
        """Copy shifted by `t` (m)."""
        return dataclasses.replace(self, center=tuple(np.add(self.center, t)))


@dataclasses.dataclass(frozen=True, eq=False)
class ConvexMesh:
    """Convex polyhedron given by vertices (n, 3) in m; the faces are those of its convex hull."""

    name: str
    vertices: np.ndarray

    def __post_init__(self):
        v = np.asarray(self.vertices, float)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 4:
            raise ParameterError(f"convex part {self.name!r} needs at least 4 vertices (n, 3)")
        try:
            hull = ConvexHull(v)
        except QhullError:
            hull = None
        if hull is None or hull.volume <= 0:
            raise ParameterError(f"convex part {self.name!r} is flat (zero volume)")
        object.__setattr__(self, "vertices", v[hull.vertices])
        object.__setattr__(self, "_hull", ConvexHull(v[hull.vertices]))

    @property
    def faces(self) -> np.ndarray:
        """Outward-oriented triangle faces (m, 3) indexing `vertices`."""
        hull = self._hull
        faces = hull.simplices.copy()
        v = self.vertices
        n = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
        flip = np.sum(n * hull.equations[:, :3], axis=1) < 0
        faces[flip] = faces[flip][:, ::-1]
        return faces

    def volume(self, solid: bool = True) -> float:
        """Volume (m^3)."""
        return float(self._hull.volume)

    def moments(self, solid: bool = True) -> Moments:
        """Exact volume moments about the body origin."""
        return mesh_moments(self.vertices, self.faces)

    def contains(self, pts: np.ndarray, solid: bool = True) -> np.ndarray:
        """Whether each point (n, 3) lies inside."""
        eq = self._hull.equations
        return np.all(pts @ eq[:, :3].T + eq[:, 3] <= 1e-12, axis=1)

    def sample(self, n: int, rng: np.random.Generator, solid: bool = True) -> np.ndarray:
        """`n` points uniformly distributed inside (rejection in the bounding box)."""
        lo, hi = self.bounds()
        out: list[np.ndarray] = []
        count = 0
        while count < n:
            q = rng.uniform(lo, hi, size=(4 * n, 3))
            q = q[self.contains(q)]
            out.append(q)
            count += len(q)
        return np.concatenate(out)[:n]

    def hull_points(self) -> np.ndarray:
        """The vertices (m)."""
        return self.vertices

    def bounds(self) -> np.ndarray:
        """Axis-aligned bounds (m), exact."""
        return np.array([self.vertices.min(0), self.vertices.max(0)])

    def max_radius(self) -> float:
        """Largest horizontal distance (m) from the body's z axis, exact."""
        return float(np.max(np.hypot(self.vertices[:, 0], self.vertices[:, 1])))

    def translated(self, t: np.ndarray) -> ConvexMesh:
        """Copy shifted by `t` (m)."""
        return ConvexMesh(self.name, self.vertices + np.asarray(t, float))


Part = Capsule | Cylinder | Sphere | Box | ConvexMesh


def union_moments(parts: Sequence[Part], solid: bool = True, samples_per_part: int = 10000,
                  seed: int = 0) -> Moments:
    """Volume moments of the union of `parts`: exact part moments minus a Monte Carlo overlap term.

    `solid` selects the region enclosed by each part (True) or its mass-carrying material (False,
    differs only for shelled spheres). The estimate is exact when no two parts overlap.
    """
    rng = np.random.default_rng(seed)
    total = Moments.zero()
    for part in parts:
        total = total + part.moments(solid)
    boxes = [p.bounds() for p in parts]
    surplus = Moments.zero()
    for i, part in enumerate(parts):
        others = [j for j in range(len(parts)) if j != i
                  and np.all(boxes[j][0] <= boxes[i][1]) and np.all(boxes[i][0] <= boxes[j][1])]
        if not others:
            continue
        pts = part.sample(samples_per_part, rng, solid)
        count = np.ones(len(pts))
        for j in others:
            near = np.flatnonzero(np.all((pts >= boxes[j][0]) & (pts <= boxes[j][1]), axis=1))
            count[near] += parts[j].contains(pts[near], solid)
        w = part.volume(solid) / len(pts) * (1.0 - 1.0 / count)
        if not np.any(w):
            continue
        surplus = surplus + Moments(float(w.sum()), (w[:, None] * pts).sum(0),
                                    np.einsum("n,ni,nj->ij", w, pts, pts))
    return total - surplus


def hull_points(parts: Sequence[Part]) -> np.ndarray:
    """Points (n, 3) whose convex hull approximates that of the union of `parts`."""
    return np.concatenate([p.hull_points() for p in parts])


def hull_volume(points: np.ndarray) -> float:
    """Volume (m^3) of the convex hull of `points`."""
    return float(ConvexHull(np.asarray(points, float)).volume)


@dataclasses.dataclass(frozen=True, eq=False)
class Shape:
    """What an object builder returns: collision parts (m) plus its mass and named dimensions.

    `material` overrides the mass-carrying region's moments (default: union of the parts' material),
    `volume_m3` the enclosed volume (default: union of the solid parts) and `hull` the points whose
    convex hull is the object's (default: the parts' hull points); mesh objects use the source
    mesh for all three.
    `axis_xy` is the object's vertical axis in x, y (default: the centre of its bounding box).
    `notes` says what was repaired or approximated. `orientation_free`: every orientation of the object is
    the same object (a ball), so a grasp is not judged by how upright it holds it.
    """

    parts: tuple[Part, ...]
    mass_kg: float
    dims: dict[str, float]
    material: Moments | None = None
    volume_m3: float | None = None
    hull: np.ndarray | None = None
    axis_xy: tuple[float, float] | None = None
    notes: tuple[str, ...] = ()
    orientation_free: bool = False
