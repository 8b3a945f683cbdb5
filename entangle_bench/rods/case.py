"""Rod cases (one clamped elastic rod, JSON) and rod results (a centerline, NPZ).

Rod-case file schema (JSON object, SI units; every key below is required unless marked optional,
and unknown keys are rejected)::

    {
      "name": "soft_cantilever",            # non-empty string
      "description": "...",                  # optional string
      "length": 0.3,                         # rod length L beyond the clamp (m), > 0
      "radius": 0.0007,                      # circular cross-section radius r (m), > 0
      "youngs_modulus": 1.0e6,               # E (Pa), > 0
      "poisson_ratio": 0.5,                  # nu in (-1, 0.5]; shear modulus G = E / (2 (1 + nu))
      "density": 1100.0,                     # rho (kg/m^3), > 0
      "gravity": [0.0, 0.0, -9.81],          # uniform acceleration (m/s^2)
      "base": {
        "position": [0.0, 0.0, 0.5],         # clamp point (m)
        "direction": [1.0, 0.0, 0.0],        # tangent t at the clamp (normalised on load)
        "normal": [0.0, 0.0, 1.0]            # first material director d1 at the clamp, _|_ t
      },
      "intrinsic_curvature": [0.0, 0.0],     # rest curvature (k1, k2) about d1 and d2 (1/m)
      "intrinsic_twist": 0.0                 # rest twist tau about t (rad/m)
    }

The rod is clamped at ``base.position`` and free at the other end. The material frame is
(t, d1, d2) with d2 = t x d1 (the MuJoCo segment frame: local x, y, z). The rest Darboux vector
is uniform, omega0 = tau t + k1 d1 + k2 d2, with d' = omega0 x d for every frame vector d, so a
positive k2 bends the rest shape toward +d1 and a positive k1 toward -d2.

Rod results hold the computed equilibrium centerline at uniform arclength from base to tip; see
`RodResult`. `resample_centerline` and `centerline_error` are shared by all engines.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from scipy.interpolate import CubicSpline

from entangle_bench import resources
from entangle_bench.atomic import atomic_save_npz
from entangle_bench.config import check_range
from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.registry import Registry

_REQUIRED = (
    "name",
    "length",
    "radius",
    "youngs_modulus",
    "poisson_ratio",
    "density",
    "gravity",
    "base",
    "intrinsic_curvature",
    "intrinsic_twist",
)
_OPTIONAL = ("description",)
_BASE_KEYS = ("position", "direction", "normal")
_PERPENDICULAR_TOL = 1e-6
_ARCLENGTH_SUBDIVISION = 64  # fine polyline per spline interval for arclength (error ~1e-7 h)


def _number(value: Any, where: str) -> float:
    """Return `value` as a finite float or raise FileFormatError naming `where`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise FileFormatError(f"{where}: expected a number, got {value!r}")
    if not math.isfinite(value):
        raise FileFormatError(f"{where}: expected a finite number, got {value!r}")
    return float(value)


def _vector(value: Any, size: int, where: str) -> tuple[float, ...]:
    """Return `value` as a tuple of `size` finite floats or raise FileFormatError."""
    if not isinstance(value, (list, tuple)):
        raise FileFormatError(f"{where}: expected a list of {size} numbers, got {value!r}")
    if len(value) != size:
        raise FileFormatError(f"{where}: expected {size} numbers, got {len(value)}")
    return tuple(_number(v, f"{where}[{i}]") for i, v in enumerate(value))


def _positive(value: Any, where: str) -> float:
    """Return `value` as a float > 0 or raise FileFormatError."""
    number = _number(value, where)
    if number <= 0.0:
        raise FileFormatError(f"{where}: must be > 0, got {number!r}")
    return number


def _unit(vector: tuple[float, ...], where: str) -> tuple[float, float, float]:
    """Return `vector` normalised to unit length; FileFormatError if it is zero."""
    norm = math.sqrt(sum(v * v for v in vector))
    if norm < 1e-12:
        raise FileFormatError(f"{where}: must be a non-zero vector, got {list(vector)}")
    return (vector[0] / norm, vector[1] / norm, vector[2] / norm)


@dataclass(frozen=True)
class RodCase:
    """One clamped-free elastic rod with uniform circular section; all fields in SI units.

    `length` (m), `radius` (m), `youngs_modulus` (Pa), `poisson_ratio` (-), `density` (kg/m^3),
    `gravity` (m/s^2), `base_position` (m), unit `base_direction` and `base_normal`,
    `intrinsic_curvature` (k1, k2) about (d1, d2) in 1/m, `intrinsic_twist` (rad/m).
    """

    name: str
    length: float
    radius: float
    youngs_modulus: float
    poisson_ratio: float
    density: float
    gravity: tuple[float, float, float]
    base_position: tuple[float, float, float]
    base_direction: tuple[float, float, float]
    base_normal: tuple[float, float, float]
    intrinsic_curvature: tuple[float, float] = (0.0, 0.0)
    intrinsic_twist: float = 0.0
    description: str = ""
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        """Check ranges and that the base frame is orthonormal."""
        if not self.name:
            raise ParameterError("name must be a non-empty string")
        check_range("length", self.length, 0.0, None, low_open=True)
        check_range("radius", self.radius, 0.0, None, low_open=True)
        check_range("youngs_modulus", self.youngs_modulus, 0.0, None, low_open=True)
        check_range("poisson_ratio", self.poisson_ratio, -1.0, 0.5, low_open=True)
        check_range("density", self.density, 0.0, None, low_open=True)
        for name in ("gravity", "base_position", "base_direction", "base_normal"):
            if len(getattr(self, name)) != 3:
                raise ParameterError(f"{name} must have 3 components")
        if len(self.intrinsic_curvature) != 2:
            raise ParameterError("intrinsic_curvature must have 2 components")
        for name in (
            "gravity",
            "base_position",
            "base_direction",
            "base_normal",
            "intrinsic_curvature",
        ):
            values = getattr(self, name)
            for i, v in enumerate(values):
                check_range(f"{name}[{i}]", v)
            object.__setattr__(self, name, tuple(float(v) for v in values))
        check_range("intrinsic_twist", self.intrinsic_twist)
        t, n = np.asarray(self.base_direction), np.asarray(self.base_normal)
        if abs(np.linalg.norm(t) - 1.0) > 1e-9 or abs(np.linalg.norm(n) - 1.0) > 1e-9:
            raise ParameterError("base_direction and base_normal must be unit vectors")
        if abs(float(t @ n)) > _PERPENDICULAR_TOL:
            raise ParameterError("base_direction and base_normal must be perpendicular")

    @classmethod
    def from_dict(cls, data: Any, source: str = "<dict>") -> RodCase:
        """Build a case from the parsed JSON object; FileFormatError names `source` and key."""
        try:
            return cls._from_dict(data, source)
        except FileFormatError as exc:
            raise FileFormatError(f"{source}: {exc}") from None
        except ParameterError as exc:
            raise FileFormatError(f"{source}: {exc}") from None

    @classmethod
    def _from_dict(cls, data: Any, source: str) -> RodCase:
        """Parse without the file name prefix (added by `from_dict`)."""
        if not isinstance(data, dict):
            raise FileFormatError(f"expected a JSON object, got {type(data).__name__}")
        unknown = sorted(set(data) - set(_REQUIRED) - set(_OPTIONAL))
        if unknown:
            known = ", ".join(_REQUIRED + _OPTIONAL)
            raise FileFormatError(f"unknown field {unknown[0]!r}; known fields: {known}")
        for key in _REQUIRED:
            if key not in data:
                raise FileFormatError(f"missing field {key!r}")
        name = data["name"]
        if not isinstance(name, str) or not name.strip():
            raise FileFormatError(f"name: expected a non-empty string, got {name!r}")
        description = data.get("description", "")
        if not isinstance(description, str):
            raise FileFormatError(f"description: expected a string, got {description!r}")
        base = data["base"]
        if not isinstance(base, dict):
            raise FileFormatError(f"base: expected an object, got {base!r}")
        unknown = sorted(set(base) - set(_BASE_KEYS))
        if unknown:
            raise FileFormatError(
                f"unknown field 'base.{unknown[0]}'; known: {', '.join(_BASE_KEYS)}"
            )
        for key in _BASE_KEYS:
            if key not in base:
                raise FileFormatError(f"missing field 'base.{key}'")
        position = _vector(base["position"], 3, "base.position")
        direction = _unit(_vector(base["direction"], 3, "base.direction"), "base.direction")
        normal = _unit(_vector(base["normal"], 3, "base.normal"), "base.normal")
        if abs(sum(a * b for a, b in zip(direction, normal))) > _PERPENDICULAR_TOL:
            raise FileFormatError(
                f"base.normal: must be perpendicular to base.direction, got {list(normal)} "
                f"and {list(direction)}"
            )
        poisson = _number(data["poisson_ratio"], "poisson_ratio")
        if not -1.0 < poisson <= 0.5:
            raise FileFormatError(f"poisson_ratio: must lie in (-1, 0.5], got {poisson!r}")
        curvature = _vector(data["intrinsic_curvature"], 2, "intrinsic_curvature")
        return cls(
            name=name,
            length=_positive(data["length"], "length"),
            radius=_positive(data["radius"], "radius"),
            youngs_modulus=_positive(data["youngs_modulus"], "youngs_modulus"),
            poisson_ratio=poisson,
            density=_positive(data["density"], "density"),
            gravity=_vector(data["gravity"], 3, "gravity"),
            base_position=position,
            base_direction=direction,
            base_normal=normal,
            intrinsic_curvature=(curvature[0], curvature[1]),
            intrinsic_twist=_number(data["intrinsic_twist"], "intrinsic_twist"),
            description=description,
            source=source,
        )

    def to_dict(self) -> dict[str, Any]:
        """Return the JSON object of this case (the inverse of `from_dict`)."""
        data: dict[str, Any] = {
            "name": self.name,
            "length": self.length,
            "radius": self.radius,
            "youngs_modulus": self.youngs_modulus,
            "poisson_ratio": self.poisson_ratio,
            "density": self.density,
            "gravity": list(self.gravity),
            "base": {
                "position": list(self.base_position),
                "direction": list(self.base_direction),
                "normal": list(self.base_normal),
            },
            "intrinsic_curvature": list(self.intrinsic_curvature),
            "intrinsic_twist": self.intrinsic_twist,
        }
        if self.description:
            data["description"] = self.description
        return data

    @property
    def area(self) -> float:
        """Cross-section area pi r^2 (m^2)."""
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        """Area second moment of the circular section pi r^4 / 4 (m^4)."""
        return math.pi * self.radius**4 / 4.0

    @property
    def shear_modulus(self) -> float:
        """Shear modulus G = E / (2 (1 + nu)) (Pa)."""
        return self.youngs_modulus / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def bending_stiffness(self) -> float:
        """Bending stiffness E I (N m^2)."""
        return self.youngs_modulus * self.second_moment

    @property
    def twist_stiffness(self) -> float:
        """Torsional stiffness G J with polar moment J = 2 I (N m^2)."""
        return self.shear_modulus * 2.0 * self.second_moment

    @property
    def line_density(self) -> float:
        """Mass per length rho A (kg/m)."""
        return self.density * self.area

    @property
    def base_frame(self) -> np.ndarray:
        """3x3 rotation whose columns are (t, d1, d2) at the clamp, world coordinates."""
        t = np.asarray(self.base_direction, dtype=float)
        d1 = np.asarray(self.base_normal, dtype=float)
        return np.column_stack([t, d1, np.cross(t, d1)])

    @property
    def darboux(self) -> np.ndarray:
        """Rest Darboux vector (tau, k1, k2) in the material frame (t, d1, d2), 1/m."""
        return np.array([self.intrinsic_twist, *self.intrinsic_curvature], dtype=float)


def case_key(case: RodCase) -> str:
    """Short hash (hex) of the case's content: stored and cached results are valid for identical cases only."""
    text = json.dumps(case.to_dict(), sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


#: The packaged rod cases (`tasks/rod_cases/*.json`) by name, the file stem: `entangle-bench rod soft_cantilever`.
ROD_CASES: Registry[Path] = Registry("rod case")
for _path in sorted(resources.rod_cases_dir().glob("*.json")):
    ROD_CASES.add(_path.stem, _path, description="")


def case_path(name_or_path: str | os.PathLike[str]) -> Path:
    """The rod-case file meant: an existing file (relative to the current folder), else a packaged case by name.

    A missing file given as a path (a folder part or a .json suffix) raises FileFormatError; an unknown bare
    name raises UnknownNameError; both list the packaged cases.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.suffix == ".json" or len(path.parts) > 1:
        raise FileFormatError(f"{path}: no such rod-case file; packaged rod cases, by name: "
                              f"{', '.join(ROD_CASES.names())}")
    return ROD_CASES.get(str(name_or_path))


def load_case(path: str | os.PathLike[str]) -> RodCase:
    """Read a rod-case JSON file; FileFormatError names the file and the offending field."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise FileFormatError(f"{path}: cannot read rod case: {exc.strerror}") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise FileFormatError(f"{path}: not valid JSON: {exc}") from None
    return RodCase.from_dict(data, source=str(path))


@dataclass(frozen=True)
class RodResult:
    """An equilibrium centerline: (M, 3) points in m at uniform arclength from base to tip.

    `engine` names the simulator, `wall_time_s` is its wall-clock time (s) and `settings` holds
    JSON-serialisable parameters of the run (resolution, time step, ...).
    """

    centerline: np.ndarray
    engine: str
    wall_time_s: float
    settings: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        """Check the centerline shape and the wall time."""
        points = np.asarray(self.centerline, dtype=float)
        if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 2:
            raise ParameterError(f"centerline must have shape (M>=2, 3), got {points.shape}")
        if not np.all(np.isfinite(points)):
            raise ParameterError("centerline contains non-finite values")
        check_range("wall_time_s", self.wall_time_s, 0.0, None)
        object.__setattr__(self, "centerline", points)

    def save_npz(self, path: str | os.PathLike[str]) -> None:
        """Write the result to `path` (NPZ) atomically: temp file in the same folder, then rename."""
        atomic_save_npz(
            path,
            compressed=False,
            centerline=self.centerline,
            engine=np.array(self.engine),
            wall_time_s=np.array(self.wall_time_s),
            settings=np.array(json.dumps(self.settings, sort_keys=True)),
        )

    @classmethod
    def load_npz(cls, path: str | os.PathLike[str]) -> RodResult:
        """Read a result written by `save_npz`; FileFormatError if missing or malformed."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = [
                    k
                    for k in ("centerline", "engine", "wall_time_s", "settings")
                    if k not in data.files
                ]
                if missing:
                    raise FileFormatError(f"{path}: missing field {missing[0]!r}")
                return cls(
                    centerline=data["centerline"],
                    engine=str(data["engine"]),
                    wall_time_s=float(data["wall_time_s"]),
                    settings=json.loads(str(data["settings"])),
                )
        except (OSError, ValueError) as exc:
            if isinstance(exc, FileFormatError):
                raise
            raise FileFormatError(f"{path}: not a rod result file: {exc}") from None


def resample_centerline(
    points: np.ndarray, m: int, method: Literal["cubic", "linear"] = "cubic"
) -> np.ndarray:
    """Resample a polyline (N, 3) in m to `m` points at uniform arclength, base to tip.

    "linear" places the points at uniform arclength along the polyline itself. "cubic" (default)
    interpolates the points with a not-a-knot cubic spline in cumulative chord length (error
    O(h^4) on smooth curves) and places the points at uniform arclength of that spline.
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 2:
        raise ParameterError(f"points must have shape (N>=2, 3), got {points.shape}")
    check_range("m", m, 2, None)
    if method not in ("cubic", "linear"):
        raise ParameterError(f"method = {method!r} is not allowed; choose 'cubic' or 'linear'")
    chord = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if np.any(chord <= 0.0):
        raise ParameterError("centerline has repeated consecutive points")
    u = np.concatenate([[0.0], np.cumsum(chord)])
    if method == "linear" or points.shape[0] < 4:
        targets = np.linspace(0.0, u[-1], int(m))
        return np.column_stack([np.interp(targets, u, points[:, k]) for k in range(3)])
    spline = CubicSpline(u, points, axis=0)
    fine_u = np.linspace(0.0, u[-1], _ARCLENGTH_SUBDIVISION * (points.shape[0] - 1) + 1)
    fine = spline(fine_u)
    arclength = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(fine, axis=0), axis=1))])
    targets = np.linspace(0.0, arclength[-1], int(m))
    return spline(np.interp(targets, arclength, fine_u))


def centerline_error(a: np.ndarray, b: np.ndarray, length: float) -> tuple[float, float]:
    """Return (max, rms) distance between centerlines `a` and `b`, divided by `length` (m).

    Both are resampled to uniform arclength with max(len(a), len(b)) points, so that point i of
    each sits at the same fraction of its own length, then compared point by point.
    """
    check_range("length", length, 0.0, None, low_open=True)
    m = max(len(a), len(b))
    pa, pb = resample_centerline(a, m), resample_centerline(b, m)
    dist = np.linalg.norm(pa - pb, axis=1)
    return float(dist.max() / length), float(np.sqrt(np.mean(dist**2)) / length)
