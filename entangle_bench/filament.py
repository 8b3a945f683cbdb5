"""One soft pneumatic filament: parameters, section mechanics, the actuation law and the MuJoCo chain.

The filament is a discrete elastic rod (Bergou et al., "Discrete elastic rods", SIGGRAPH 2008): a chain of
capsule bodies of length ds joined by ball joints whose springs carry bending and twist. The joint at vertex j
(arclength s = j ds) has stiffness EI/ds (the Voronoi length of an interior vertex); the clamp joint at s = 0 has
the half Voronoi length, so stiffness 2 EI/ds and half the rest rotation, which makes the clamp second-order
accurate. Rest shape (the spring reference `qpos_spring`) is a uniform Darboux vector
Omega = tau t + k1 d1 + k2 d2 in the material frame: the rest rotation between consecutive segments is
exp(ds [Omega]x), the discrete analogue of a rod with uniform intrinsic curvature and twist (Kirchhoff rod).

Frame: each segment body's local x axis is the tangent t, local y the first material director d1, local z the
second director d2 = t x d1 (the layout of MuJoCo's composite cable).

Actuation follows the scaling law of an eccentric-channel elastomer tube (Becker et al., PNAS 2022):
kappa = c * p * (1 - delta)^2 * eps / (r * E).

`add_filament` is the only function that knows how a filament becomes MuJoCo elements, so a move to MuJoCo 4.x
1D flexcomp rods touches this module alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.config import check_range
from entangle_bench.errors import ParameterError
from entangle_bench.presets import DEFAULT_PRESET, PRESETS

#: Default operating pressure of the reference gripper (Becker et al. 2022), Pa.
REFERENCE_PRESSURE_PA = 172e3

#: Default free coil radius of the reference filament at REFERENCE_PRESSURE_PA, m (our calibration target).
REFERENCE_COIL_RADIUS_M = 0.0125


@dataclass(frozen=True)
class FilamentParams:
    """Physical parameters of one filament (SI units).

    Defaults describe the reference design: a 300 mm silicone tube of 1.4 mm outer diameter (aspect ratio
    L / (2r) = 214 > 200), a channel of half the outer radius set off-center halfway to the wall, a soft
    silicone elastomer (E = 1 MPa, nu = 0.49, rho = 1100 kg/m^3, typical of platinum-cure silicones such as
    Dragon Skin / Elastosil), and the calibration c chosen so that 172 kPa curls the free filament to a coil of
    radius REFERENCE_COIL_RADIUS_M (12.5 mm).
    """

    length_m: float = 0.300
    outer_radius_m: float = 0.7e-3
    channel_radius_ratio: float = 0.5
    """delta = channel radius / outer radius, in [0, 1)."""
    channel_eccentricity: float = 0.5
    """eps in [0, 1]: channel center offset as a fraction of the largest offset (1 - delta) r."""
    youngs_modulus_pa: float = 1.0e6
    poisson_ratio: float = 0.49
    density_kg_m3: float = 1100.0
    n_segments: int = PRESETS[DEFAULT_PRESET].n_segments
    """Capsule segments of the chain; the default is the default numerical preset's (presets set it per run)."""
    damping_time_s: float = 0.02
    """Kelvin-Voigt relaxation time: each joint's damping is its stiffness times this, N m s/rad."""
    curvature_calibration: float = float("nan")
    """Dimensionless c of the actuation law; NaN means the calibrated default (see `default_calibration`)."""
    twist_hinge: bool = False
    """Give each segment a twist hinge in series with its ball joint so that the twist stiffness is G J, not
    the ball spring's isotropic E I (see `add_filament`); False is the plain ball chain."""

    def __post_init__(self) -> None:
        check_range("filament.length_m", self.length_m, 0.0, None, low_open=True)
        check_range("filament.outer_radius_m", self.outer_radius_m, 0.0, None, low_open=True)
        check_range(
            "filament.outer_radius_m (relative to length_m/4)",
            self.outer_radius_m,
            None,
            self.length_m / 4,
        )
        check_range("filament.channel_radius_ratio", self.channel_radius_ratio, 0.0, 1.0, high_open=True)
        check_range("filament.channel_eccentricity", self.channel_eccentricity, 0.0, 1.0)
        check_range("filament.youngs_modulus_pa", self.youngs_modulus_pa, 0.0, None, low_open=True)
        check_range("filament.poisson_ratio", self.poisson_ratio, -1.0, 0.5, low_open=True)
        check_range("filament.density_kg_m3", self.density_kg_m3, 0.0, None, low_open=True)
        if isinstance(self.n_segments, bool) or not isinstance(self.n_segments, int):
            raise ParameterError(f"filament.n_segments = {self.n_segments!r} must be an integer >= 2")
        check_range("filament.n_segments", self.n_segments, 2, 1000)
        check_range("filament.damping_time_s", self.damping_time_s, 0.0, 10.0)
        if not math.isnan(self.curvature_calibration):
            check_range("filament.curvature_calibration", self.curvature_calibration, 0.0, None)
        if self.twist_hinge and self.torsional_stiffness_nm2 > self.bending_stiffness_nm2 * (1 + 1e-9):
            raise ParameterError(
                f"filament.twist_hinge needs G J <= E I (poisson_ratio >= 0 for a round tube); got "
                f"G J = {self.torsional_stiffness_nm2:.3g} N m^2, E I = {self.bending_stiffness_nm2:.3g} N m^2"
            )

    @property
    def segment_length_m(self) -> float:
        """Length of one segment ds, m."""
        return self.length_m / self.n_segments

    @property
    def channel_radius_m(self) -> float:
        """Radius of the pressure channel, m."""
        return self.channel_radius_ratio * self.outer_radius_m

    @property
    def channel_offset_m(self) -> float:
        """Distance from the tube axis to the channel axis, m."""
        return self.channel_eccentricity * (1.0 - self.channel_radius_ratio) * self.outer_radius_m

    @property
    def area_m2(self) -> float:
        """Cross-section area of the wall, m^2."""
        return math.pi * (self.outer_radius_m**2 - self.channel_radius_m**2)

    @property
    def linear_density_kg_m(self) -> float:
        """Mass per unit length, kg/m."""
        return self.density_kg_m3 * self.area_m2

    @property
    def mass_kg(self) -> float:
        """Total filament mass, kg."""
        return self.linear_density_kg_m * self.length_m

    @property
    def second_moments_m4(self) -> tuple[float, float]:
        """Area moments (I_bend, I_side) about the centroid: in the channel-offset (curling) plane and across it, m^4.

        The eccentric channel shifts the centroid by y_c = -a^2 e / (r^2 - a^2); parallel-axis theorem for both
        circles (Timoshenko & Gere, Mechanics of Materials).
        """
        r, a, e = self.outer_radius_m, self.channel_radius_m, self.channel_offset_m
        yc = -(a**2) * e / (r**2 - a**2)
        i_bend = math.pi * r**4 / 4 + math.pi * r**2 * yc**2 - (
            math.pi * a**4 / 4 + math.pi * a**2 * (e - yc) ** 2
        )
        i_side = math.pi * (r**4 - a**4) / 4
        return i_bend, i_side

    @property
    def bending_stiffness_nm2(self) -> float:
        """EI in the curling plane, N m^2 (the ball-joint spring is isotropic, so this EI is used for both axes)."""
        return self.youngs_modulus_pa * self.second_moments_m4[0]

    @property
    def shear_modulus_pa(self) -> float:
        """G = E / (2 (1 + nu)), Pa."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def torsional_stiffness_nm2(self) -> float:
        """GJ with J = I_bend + I_side (polar moment), N m^2."""
        return self.shear_modulus_pa * sum(self.second_moments_m4)

    @property
    def twist_hinge_stiffness_nm(self) -> float:
        """Stiffness of an interior segment's series twist hinge, N m/rad: 1 / (ds (1/GJ - 1/EI)).

        In series with the ball spring's twist stiffness EI/ds it gives the rod's GJ/ds; infinite (no hinge
        needed) when GJ >= EI, e.g. a solid round rod at poisson_ratio 0.
        """
        gj, ei = self.torsional_stiffness_nm2, self.bending_stiffness_nm2
        if gj >= ei * (1 - 1e-9):
            return math.inf
        return 1.0 / (self.segment_length_m * (1.0 / gj - 1.0 / ei))

    @property
    def gravity_length_m(self) -> float:
        """Elasto-gravity length l_g = (EI / (rho A g))^(1/3), m: filaments longer than this droop."""
        return (self.bending_stiffness_nm2 / (self.linear_density_kg_m * 9.81)) ** (1 / 3)

    @property
    def calibration(self) -> float:
        """Dimensionless c of the actuation law actually in use."""
        if math.isnan(self.curvature_calibration):
            return default_calibration(self)
        return self.curvature_calibration

    def curvature_per_m(self, pressure_pa: float) -> float:
        """Actuated rest curvature kappa = c p (1 - delta)^2 eps / (r E), 1/m."""
        return pressure_law(self, pressure_pa, self.calibration)


def pressure_law(params: FilamentParams, pressure_pa: float, calibration: float) -> float:
    """kappa = c p (1 - delta)^2 eps / (r E), 1/m (Becker et al. 2022 scaling)."""
    check_range("pressure_pa", pressure_pa, 0.0, 2e6)
    return (
        calibration
        * pressure_pa
        * (1.0 - params.channel_radius_ratio) ** 2
        * params.channel_eccentricity
        / (params.outer_radius_m * params.youngs_modulus_pa)
    )


def default_calibration(params: FilamentParams) -> float:
    """c such that the default filament at 172 kPa curls to a coil of radius 12.5 mm.

    Computed from the *default* geometry and modulus, so c is a material/design constant: changing E, r,
    delta or eps of a filament changes its curvature through the law, not through c.
    """
    ref = DEFAULT_GEOMETRY
    return 1.0 / REFERENCE_COIL_RADIUS_M / pressure_law(ref, REFERENCE_PRESSURE_PA, 1.0)


DEFAULT_GEOMETRY = FilamentParams(curvature_calibration=1.0)


def rest_rotation_quat(darboux: np.ndarray, ds: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of exp(ds [Omega]x) for a Darboux vector Omega = (tau, k1, k2) in body axes."""
    rotvec = np.asarray(darboux, dtype=float) * ds
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-15:
        return np.array([1.0, 0.0, 0.0, 0.0])
    axis = rotvec / angle
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])


@dataclass(frozen=True)
class FilamentHandle:
    """Names and compiled indices of one filament in a model."""

    index: int
    body_names: tuple[str, ...]
    geom_names: tuple[str, ...]
    joint_names: tuple[str, ...]
    """Ball joints, root to tip (their qpos_spring holds the rest shape)."""
    twist_names: tuple[str, ...] = ()
    """Series twist hinges, root to tip (empty for a plain ball chain)."""

    def qpos_addresses(self, model: mujoco.MjModel) -> np.ndarray:
        """(n, 4) indices into qpos / qpos_spring of each ball joint's quaternion."""
        adr = [model.joint(name).qposadr[0] for name in self.joint_names]
        return np.asarray(adr)[:, None] + np.arange(4)[None, :]

    def twist_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """Joint ids of the series twist hinges, root to tip (empty without hinges)."""
        return np.array([model.joint(name).id for name in self.twist_names], dtype=int)

    def body_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """Body ids from root to tip."""
        return np.array([model.body(name).id for name in self.body_names])


def body_name(index: int, segment: int) -> str:
    """Name of segment body `segment` of filament `index`."""
    return f"f{index:02d}_b{segment:03d}"


def geom_name(index: int, segment: int) -> str:
    """Name of segment capsule `segment` of filament `index`."""
    return f"f{index:02d}_g{segment:03d}"


def joint_name(index: int, segment: int) -> str:
    """Name of the ball joint at the root of segment `segment` of filament `index`."""
    return f"f{index:02d}_j{segment:03d}"


def twist_name(index: int, segment: int) -> str:
    """Name of the twist hinge at the root of segment `segment` of filament `index`."""
    return f"f{index:02d}_t{segment:03d}"


def add_filament(
    parent: mujoco.MjsBody,
    params: FilamentParams,
    index: int,
    pos: tuple[float, float, float],
    quat: tuple[float, float, float, float],
    twist_armature_scale: float = 1.0,
    rgba: tuple[float, float, float, float] = (0.2, 0.5, 0.9, 1.0),
) -> FilamentHandle:
    """Add one clamped filament as a child chain of `parent`; `pos`/`quat` place the clamp frame (x = tangent).

    `twist_armature_scale` adds joint armature equal to (scale - 1) times the segment's own spin inertia. It
    targets torsional waves (the fastest mode of a thin rod) and so allows a larger timestep without changing
    any static equilibrium; note that MuJoCo applies a ball joint's armature to all three of its rotational
    DOFs, so bending rotations get the same (small) added inertia, which slows the fastest bending dynamics
    too (measured in the accuracy-time study: swing error 0.30 L at x1 vs 0.43 L at x1000).

    With `params.twist_hinge`, each body gets a hinge before its ball joint whose axis is the rest
    mid-tangent between the two segments (x while straight; `rest_twist_axes` gives it for a curved rest
    shape, and actuation rewrites `model.jnt_axis`). The hinge spring is in series with the ball spring's
    twist: together they give twist stiffness GJ/ds while bending keeps EI/ds, second-order accurate like
    the rest of the chain. The hinge gets the ball joint's armature, at least the segment's spin inertia.
    """
    check_range("twist_armature_scale", twist_armature_scale, 1.0, 1e6)
    n, ds = params.n_segments, params.segment_length_m
    r_out, r_in = params.outer_radius_m, params.channel_radius_m
    m = params.linear_density_kg_m * ds
    i_axial = 0.5 * m * (r_out**2 + r_in**2)
    i_trans = m * (ds**2 / 12.0 + (r_out**2 + r_in**2) / 4.0)
    k_bend = params.bending_stiffness_nm2 / ds
    armature = (twist_armature_scale - 1.0) * i_axial
    bodies, geoms, joints, twists = [], [], [], []
    body = parent
    for j in range(n):
        body = body.add_body(
            name=body_name(index, j),
            pos=pos if j == 0 else (ds, 0.0, 0.0),
            quat=quat if j == 0 else (1.0, 0.0, 0.0, 0.0),
            mass=m,
            ipos=(ds / 2, 0.0, 0.0),
            inertia=(i_axial, i_trans, i_trans),
            explicitinertial=True,
        )
        if params.twist_hinge and math.isfinite(params.twist_hinge_stiffness_nm):
            # MuJoCo allows no rotation after a ball joint in one body, so the hinge comes first; its axis is
            # set to the rest mid-tangent whenever the rest shape changes (`rest_twist_axes`).
            k_twist = (2.0 if j == 0 else 1.0) * params.twist_hinge_stiffness_nm
            body.add_joint(
                name=twist_name(index, j),
                type=mujoco.mjtJoint.mjJNT_HINGE,
                axis=(1.0, 0.0, 0.0),
                stiffness=k_twist,
                damping=k_twist * params.damping_time_s,
                armature=max(armature, i_axial),
            )
            twists.append(twist_name(index, j))
        stiffness = 2.0 * k_bend if j == 0 else k_bend
        body.add_joint(
            name=joint_name(index, j),
            type=mujoco.mjtJoint.mjJNT_BALL,
            stiffness=stiffness,
            damping=stiffness * params.damping_time_s,
            armature=armature,
        )
        body.add_geom(
            name=geom_name(index, j),
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=(0.0, 0.0, 0.0, ds, 0.0, 0.0),
            size=(r_out, 0.0, 0.0),
            rgba=rgba,
            mass=0.0,
        )
        bodies.append(body_name(index, j))
        geoms.append(geom_name(index, j))
        joints.append(joint_name(index, j))
    return FilamentHandle(index, tuple(bodies), tuple(geoms), tuple(joints), tuple(twists))


def rest_quaternions(n_segments: int, ds: float, darboux: np.ndarray) -> np.ndarray:
    """(n, 4) spring reference quaternions for a uniform Darboux vector (tau, k1, k2), 1/m.

    The clamp joint (index 0) carries half the rotation, matching its half Voronoi length.
    """
    out = np.empty((n_segments, 4))
    out[0] = rest_rotation_quat(darboux, ds / 2)
    out[1:] = rest_rotation_quat(darboux, ds)
    return out


def rest_twist_axes(n_segments: int, ds: float, darboux: np.ndarray) -> np.ndarray:
    """(n, 3) twist-hinge axes in each parent frame: x turned by half the joint's rest rotation (mid-tangent).

    The clamp joint carries half a rotation (`rest_quaternions`), so its axis is turned by a quarter.
    """
    out = np.empty((n_segments, 3))
    for j, portion in ((0, 0.25), (1, 0.5)):
        quat = rest_rotation_quat(darboux, portion * ds)
        mujoco.mju_rotVecQuat(out[j], np.array([1.0, 0.0, 0.0]), quat)
    out[2:] = out[1]
    return out
