"""The filament-array gripper: layout on a hub, MuJoCo assembly and pressure actuation.

The hub is a mocap body: the harness moves it kinematically (approach, lift) by writing `data.mocap_pos`, so
the filament roots follow a prescribed trajectory exactly and each filament stays its own kinematic tree
(no coupling through a hub mass matrix). One shared pressure source drives every filament: actuation writes
the springs' reference pose `model.qpos_spring`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np

from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.filament import ChainJoints, FilamentHandle, FilamentParams, add_filament, rest_hinges

BendingPlaneMode = Literal["random", "radial_out", "radial_in", "tangential", "fixed"]

#: Clamp frame of a hanging filament: tangent x -> world -z, d1 = y -> world +x, d2 = z -> world -y.
HANGING_CLAMP_QUAT = (0.5, 0.5, 0.5, -0.5)


@dataclass(frozen=True)
class GripperParams:
    """Layout and actuation of the filament array (SI units).

    Default: the reference design (Becker et al. 2022), 12 filaments: 8 evenly on a 50 mm diameter circle and
    4 evenly on a concentric 25 mm circle, one shared pressure source at 172 kPa.
    """

    filament: FilamentParams = field(default_factory=FilamentParams)
    layout: Literal["rings", "hex"] = "rings"
    ring_diameters_m: tuple[float, ...] = (0.050, 0.025)
    ring_counts: tuple[int, ...] = (8, 4)
    hex_spacing_m: float = 0.012
    """Center-to-center spacing d of the hexagonal grid layout, m."""
    hex_rings: int = 2
    """Hexagonal layout: number of hexagonal shells around the center filament (1 + 3k(k+1) filaments)."""
    bending_plane: BendingPlaneMode = "random"
    """How each filament's curling direction is chosen: random per trial (seeded), from the layout, or fixed."""
    bending_plane_angle_rad: float = 0.0
    """Curling direction (world azimuth) for `bending_plane='fixed'`, rad."""
    pressure_pa: float = 172e3
    """Operating pressure of the shared source, Pa."""
    hub_radius_m: float = 0.035

    def __post_init__(self) -> None:
        check_choice("gripper.layout", self.layout, ("rings", "hex"))
        check_choice(
            "gripper.bending_plane",
            self.bending_plane,
            ("random", "radial_out", "radial_in", "tangential", "fixed"),
        )
        check_range("gripper.pressure_pa", self.pressure_pa, 0.0, 2e6)
        check_range("gripper.hub_radius_m", self.hub_radius_m, 0.0, 1.0, low_open=True)
        if self.layout == "rings":
            if len(self.ring_diameters_m) != len(self.ring_counts) or not self.ring_counts:
                raise ParameterError(
                    "gripper.ring_diameters_m and gripper.ring_counts must be non-empty and of equal length, "
                    f"got {self.ring_diameters_m} and {self.ring_counts}"
                )
            for k, (dia, count) in enumerate(zip(self.ring_diameters_m, self.ring_counts)):
                check_range(f"gripper.ring_diameters_m[{k}]", dia, 0.0, 1.0)
                check_range(f"gripper.ring_counts[{k}]", count, 1, 500)
                if dia == 0.0 and count != 1:
                    raise ParameterError(f"gripper.ring_counts[{k}] must be 1 for a ring of diameter 0")
        else:
            check_range("gripper.hex_spacing_m", self.hex_spacing_m, 0.0, 1.0, low_open=True)
            check_range("gripper.hex_rings", self.hex_rings, 0, 20)
        pts = filament_positions(self)
        if len(pts) > 1:
            d = _pairwise_min_distance(pts)
            if d < 2.0 * self.filament.outer_radius_m:
                raise ParameterError(
                    f"filament positions overlap: two roots are {d * 1e3:.3f} mm apart, less than one filament "
                    f"diameter ({2e3 * self.filament.outer_radius_m:.3f} mm); space them further apart"
                )
        if np.max(np.linalg.norm(pts, axis=1)) > self.hub_radius_m:
            raise ParameterError(
                f"gripper.hub_radius_m = {self.hub_radius_m} is smaller than the layout's outer radius "
                f"{np.max(np.linalg.norm(pts, axis=1)):.4f} m"
            )

    @property
    def n_filaments(self) -> int:
        """Number of filaments."""
        return len(filament_positions(self))

    @property
    def actuation_energy_j(self) -> float:
        """Bending energy 0.5 EI kappa^2 L of all filaments at the operating pressure, J (the watchdog's W_act)."""
        fil = self.filament
        kappa = fil.curvature_per_m(self.pressure_pa)
        return self.n_filaments * 0.5 * fil.bending_stiffness_nm2 * kappa**2 * fil.length_m

    @property
    def areal_density(self) -> float:
        """phi_G = r^2 / d^2 with d the mean nearest-neighbour root spacing (dimensionless)."""
        pts = filament_positions(self)
        if len(pts) < 2:
            return 0.0
        dist = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
        np.fill_diagonal(dist, np.inf)
        d = float(np.mean(dist.min(axis=1)))
        return self.filament.outer_radius_m**2 / d**2


def _pairwise_min_distance(pts: np.ndarray) -> float:
    dist = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    np.fill_diagonal(dist, np.inf)
    return float(dist.min())


def filament_positions(params: GripperParams) -> np.ndarray:
    """(n, 2) root positions in the hub plane, m, outer ring first."""
    if params.layout == "rings":
        pts = []
        for dia, count in zip(params.ring_diameters_m, params.ring_counts):
            for k in range(count):
                a = 2 * math.pi * k / count
                pts.append((0.5 * dia * math.cos(a), 0.5 * dia * math.sin(a)))
        return np.array(pts, dtype=float)
    d = params.hex_spacing_m
    pts = []
    n = params.hex_rings
    for q in range(-n, n + 1):
        for r in range(max(-n, -q - n), min(n, -q + n) + 1):
            pts.append((d * (q + r / 2), d * r * math.sqrt(3) / 2))
    pts.sort(key=lambda p: (-(p[0] ** 2 + p[1] ** 2), math.atan2(p[1], p[0])))
    return np.array(pts, dtype=float)


def bending_angles(params: GripperParams, rng: np.random.Generator | None) -> np.ndarray:
    """World azimuth toward which each filament curls, rad; `rng` is required for 'random'."""
    pts = filament_positions(params)
    azimuth = np.arctan2(pts[:, 1], pts[:, 0])
    mode = params.bending_plane
    if mode == "random":
        if rng is None:
            raise ParameterError("gripper.bending_plane = 'random' needs a seeded generator")
        return rng.uniform(-math.pi, math.pi, size=len(pts))
    if mode == "radial_out":
        return azimuth
    if mode == "radial_in":
        return azimuth + math.pi
    if mode == "tangential":
        return azimuth + math.pi / 2
    return np.full(len(pts), params.bending_plane_angle_rad)


@dataclass
class Gripper:
    """A gripper added to an MjSpec; after compiling, `bind(model)` resolves indices for actuation."""

    params: GripperParams
    filaments: list[FilamentHandle]
    hub_name: str = "hub"
    _joints: ChainJoints | None = None
    _body_ids: np.ndarray | None = None

    def bind(self, model: mujoco.MjModel) -> None:
        """Resolve joint and segment body indices in a compiled model."""
        self._joints = ChainJoints.bind(model, self.filaments)
        self._body_ids = np.stack([f.body_ids(model) for f in self.filaments])

    @property
    def joints(self) -> ChainJoints:
        """The filaments' joints (rest shapes, perturbations)."""
        if self._joints is None:
            raise RuntimeError("Gripper.bind(model) must be called after compiling")
        return self._joints

    @property
    def body_ids(self) -> np.ndarray:
        """(F, n) body ids of every filament's segments, root to tip."""
        if self._body_ids is None:
            raise RuntimeError("Gripper.bind(model) must be called after compiling")
        return self._body_ids

    @property
    def root_body_ids(self) -> np.ndarray:
        """(F,) body ids of the filaments' root segments, the hub's children."""
        return self.body_ids[:, 0]

    def centerlines(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """(F, n + 1, 3) joint positions root to tip of every filament, m (needs mj_kinematics done)."""
        ds = self.params.filament.segment_length_m
        ids = self.body_ids
        out = np.empty((ids.shape[0], ids.shape[1] + 1, 3))
        out[:, :-1] = data.xpos[ids]
        out[:, -1] = data.xpos[ids[:, -1]] + ds * data.xmat[ids[:, -1]].reshape(-1, 3, 3)[:, :, 0]
        return out

    @staticmethod
    def bend_axes(angles_rad: np.ndarray) -> np.ndarray:
        """(F, 3) curl axes in each clamp frame for the given world azimuths of the bending planes."""
        psi = np.asarray(angles_rad, dtype=float)
        return np.stack([np.zeros_like(psi), np.sin(psi), np.cos(psi)], axis=1)

    def set_pressure(self, model: mujoco.MjModel, pressure_pa: float, angles_rad: np.ndarray) -> float:
        """Write the rest shape for `pressure_pa` into the model (spring references); return kappa, 1/m.

        Hinge axes stay at `hinge_axes` at every pressure, so actuation changes only rest angles: exact rest
        shapes, and the rod's own twist and bending stiffness axes where it grasps.
        """
        fil = self.params.filament
        kappa = fil.curvature_per_m(pressure_pa)
        self.joints.set_rest_uniform(
            model,
            kappa,
            fil.twist_ratio * kappa,
            fil.segment_length_m,
            self.bend_axes(angles_rad),
            axes=self.hinge_axes,
        )
        return kappa

    @functools.cached_property
    def hinge_axes(self) -> np.ndarray:
        """(2, 3, 3) hinge axes (clamp, interior) at the material triad of the full-pressure rest shape
        (`params.pressure_pa`), for a curl about z (`rest_hinges`)."""
        fil = self.params.filament
        full = fil.curvature_per_m(self.params.pressure_pa)
        return rest_hinges(np.array([fil.twist_ratio * full, 0.0, full]), fil.segment_length_m)[0]


def add_gripper(
    spec: mujoco.MjSpec,
    params: GripperParams,
    hub_pos: tuple[float, float, float] = (0.0, 0.0, 0.5),
    twist_armature_scale: float = 1.0,
    bending_armature: bool = True,
) -> Gripper:
    """Add the hub (mocap body named 'hub') and its hanging filaments to `spec.worldbody` (armature: see
    `filament.add_filament`)."""
    hub = spec.worldbody.add_body(name="hub", pos=hub_pos, mocap=True)
    hub.add_geom(
        name="hub_disk",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=(params.hub_radius_m, 0.004, 0.0),
        pos=(0.0, 0.0, 0.004),
        contype=0,
        conaffinity=0,
        rgba=(0.3, 0.3, 0.3, 1.0),
    )
    handles = []
    for i, (x, y) in enumerate(filament_positions(params)):
        handles.append(
            add_filament(
                hub,
                params.filament,
                i,
                pos=(float(x), float(y), 0.0),
                quat=HANGING_CLAMP_QUAT,
                twist_armature_scale=twist_armature_scale,
                bending_armature=bending_armature,
            )
        )
    return Gripper(params, handles)
