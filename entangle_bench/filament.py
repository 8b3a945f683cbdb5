"""One soft pneumatic filament: parameters, section mechanics, the actuation law and the MuJoCo chain.

The filament is a discrete elastic rod (Bergou et al., "Discrete elastic rods", SIGGRAPH 2008): a chain of
capsule bodies of length ds. With `joints="hinges"` each segment joins its parent through three hinges about
the material triad at the joint's mid-point: twist about the mid-tangent (GJ/ds), out-of-plane
bending (E I_side/ds) and in-plane bending (E I_bend/ds), so twist and both bending stiffnesses are the rod's
own and the chain is right in 3D. `joints="ball"` (the default until the grasp calibration re-derives the
presets: at their coarse 2 ms numerics the hinge chain penetrates in contact) uses one ball joint with an
isotropic spring EI/ds instead, whose twist is (1 + nu) too stiff: 3-28 % of L off on curled filaments
loaded out of their plane. The clamp joint at s = 0 has the half Voronoi length, so twice the stiffness and
half the rest rotation, which makes the clamp second-order accurate. Rest shape (the spring reference
`qpos_spring`) is a uniform Darboux vector Omega = tau t + k1 d1 + k2 d2 in the material frame: the rest
rotation between consecutive segments is exp(ds [Omega]x), the discrete analogue of a rod with uniform
intrinsic curvature and twist (Kirchhoff rod); the hinge rest angles reproduce it exactly (`rest_hinges`).

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
from typing import Literal

import mujoco
import numpy as np
from scipy.optimize import least_squares

from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.presets import DEFAULT_PRESET, PRESETS

JointModel = Literal["hinges", "ball"]

#: Hinge order of the "hinges" joint model: twist (mid-tangent), out-of-plane bend, in-plane bend. The large
#: rest rotation (in-plane) comes last, so no two hinge axes can line up within 90 deg of the rest shape.
HINGE_KINDS = ("twist", "side", "bend")

#: Default operating pressure of the reference gripper (Becker et al. 2022), Pa.
REFERENCE_PRESSURE_PA = 172e3

#: Default free coil radius of the reference filament at REFERENCE_PRESSURE_PA, m (our calibration target).
REFERENCE_COIL_RADIUS_M = 0.0125

#: Stretch-joint armature per filament mass that gives a spring E A / L on it the first axial frequency of a
#: clamped-free rod, (pi / 2) sqrt(E A / (m L)): k / (4 m / pi^2) = (pi / 2)^2 k / m.
MODAL_STRETCH_ARMATURE_RATIO = 4.0 / math.pi**2


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
    twist_ratio: float = 0.0
    """Rest twist per unit rest curvature, tau / kappa: 0 curls in a plane; > 0 coils into a helix of radius
    kappa / (kappa^2 + tau^2) and pitch 2 pi tau / (kappa^2 + tau^2) that can wind past itself."""
    stretch_at_clamp: bool = False
    """Lump the filament's axial compliance L / (E A) into a slide joint at the clamp (stiffness E A / L, N/m,
    Kelvin-Voigt damping): its tension then stays what its stretch allows, as a silicone tube's does, instead of
    whatever a kinematic hub demands of an inextensible chain caught on an object."""
    stretch_armature_ratio: float = 0.0
    """Armature of the stretch joint as a fraction of the filament's mass, kg/kg (needs `stretch_at_clamp`):
    MODAL_STRETCH_ARMATURE_RATIO = 4 / pi^2 gives the lumped axial spring alone the rod's first axial
    frequency (pi / 2) sqrt(E A / (m L)); without it the joint can move the first segment alone, a mode far
    stiffer than any the rod has, whose explicit damping costs Euler its step (results/stability/candidate)."""
    joints: JointModel = "ball"
    """How each segment joins its parent: "hinges" (twist, out-of-plane and in-plane bending hinges with
    stiffness GJ, E I_side and E I_bend per segment length: right in 3D) or "ball" (one ball joint with an
    isotropic spring E I, so twist is 1.5x too stiff; see `add_filament`)."""

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
        check_choice("filament.joints", self.joints, ("hinges", "ball"))
        check_range("filament.twist_ratio", self.twist_ratio, -2.0, 2.0)
        check_range("filament.stretch_armature_ratio", self.stretch_armature_ratio, 0.0, 10.0)
        if self.stretch_armature_ratio > 0 and not self.stretch_at_clamp:
            raise ParameterError(f"filament.stretch_armature_ratio = {self.stretch_armature_ratio:g} needs "
                                 "filament.stretch_at_clamp = true (it is the armature of that joint)")

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
    def axial_stiffness_n_m(self) -> float:
        """Stiffness of the whole filament in stretch, E A / L, N/m."""
        return self.youngs_modulus_pa * self.area_m2 / self.length_m

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
    def side_bending_stiffness_nm2(self) -> float:
        """EI across the curling plane, N m^2 (out-of-plane bending of the hinge joints)."""
        return self.youngs_modulus_pa * self.second_moments_m4[1]

    @property
    def shear_modulus_pa(self) -> float:
        """G = E / (2 (1 + nu)), Pa."""
        return self.youngs_modulus_pa / (2.0 * (1.0 + self.poisson_ratio))

    @property
    def torsional_stiffness_nm2(self) -> float:
        """GJ with J = I_bend + I_side (polar moment), N m^2."""
        return self.shear_modulus_pa * sum(self.second_moments_m4)

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
    joints: JointModel
    body_names: tuple[str, ...]
    geom_names: tuple[str, ...]
    joint_names: tuple[tuple[str, ...], ...]
    """Per segment, root to tip: its ball joint, or its hinges in HINGE_KINDS order."""

    def joint_ids(self, model: mujoco.MjModel) -> np.ndarray:
        """(n, k) joint ids, root to tip (k = 1 for a ball chain, 3 for hinges)."""
        return np.array([[model.joint(name).id for name in names] for names in self.joint_names], dtype=int)

    def qpos_addresses(self, model: mujoco.MjModel) -> np.ndarray:
        """(n, 4) quaternion indices into qpos / qpos_spring (ball), or (n, 3) hinge-angle indices (hinges)."""
        adr = model.jnt_qposadr[self.joint_ids(model)]
        return adr[:, 0, None] + np.arange(4)[None, :] if self.joints == "ball" else adr

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


def stretch_name(index: int) -> str:
    """Name of the slide joint at the clamp of filament `index` (`FilamentParams.stretch_at_clamp`)."""
    return f"f{index:02d}_stretch"


def hinge_name(index: int, segment: int, kind: str) -> str:
    """Name of the `kind` hinge (one of HINGE_KINDS) at the root of segment `segment` of filament `index`."""
    return f"f{index:02d}_j{segment:03d}_{kind}"


def add_filament(
    parent: mujoco.MjsBody,
    params: FilamentParams,
    index: int,
    pos: tuple[float, float, float],
    quat: tuple[float, float, float, float],
    twist_armature_scale: float = 1.0,
    rgba: tuple[float, float, float, float] = (0.2, 0.5, 0.9, 1.0),
    bending_armature: bool = True,
) -> FilamentHandle:
    """Add one clamped filament as a child chain of `parent`; `pos`/`quat` place the clamp frame (x = tangent).

    `twist_armature_scale` adds joint armature equal to (scale - 1) times the segment's own spin inertia to
    every rotational DOF (with `bending_armature` False and hinges: to the twist hinge only). It targets
    torsional waves (the fastest mode of a thin rod) and so allows a larger timestep without changing any
    static equilibrium; on the bending DOFs it slows the fastest bending dynamics too (measured in the
    accuracy-time study: swing error 0.30 L at x1 vs 0.43 L at x1000).

    Joints ("ball"): one ball joint per segment, isotropic spring E I / ds (twist too stiff by 1 + nu).
    Joints ("hinges"): three hinges per segment whose axes, at the rest shape, are the material triad at the
    joint's mid-point: the rest mid-tangent (twist, G J / ds), the out-of-plane normal (E I_side / ds) and
    the curl axis (E I_bend / ds); `rest_hinges` sets axes and rest angles, and actuation rewrites the angles
    (`ChainJoints.set_rest_uniform` with `axes`).
    Linearized at the rest shape this is exactly the anisotropic rod stiffness; it converges at first order
    in 3D (measured on curl_sideways_gravity: 6.9e-3 L at 16 segments, 2.8e-3 L at 40) against the
    isotropic ball chain's 6.0e-2 L at any resolution. The clamp joint at s = 0 has the half Voronoi length:
    twice the stiffness and half the rest rotation, which makes the clamp second-order accurate.
    """
    check_range("twist_armature_scale", twist_armature_scale, 1.0, 1e6)
    if not bending_armature and params.joints != "hinges":
        raise ParameterError(f"bending_armature = False needs hinges, not {params.joints!r} joints")
    n, ds = params.n_segments, params.segment_length_m
    r_out, r_in = params.outer_radius_m, params.channel_radius_m
    m = params.linear_density_kg_m * ds
    i_axial = 0.5 * m * (r_out**2 + r_in**2)
    i_trans = m * (ds**2 / 12.0 + (r_out**2 + r_in**2) / 4.0)
    armature = (twist_armature_scale - 1.0) * i_axial
    hinge_stiffness = {
        "twist": params.torsional_stiffness_nm2 / ds,
        "side": params.side_bending_stiffness_nm2 / ds,
        "bend": params.bending_stiffness_nm2 / ds,
    }
    bodies, geoms, joints = [], [], []
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
        scale = 2.0 if j == 0 else 1.0
        if j == 0 and params.stretch_at_clamp:
            k = params.axial_stiffness_n_m
            body.add_joint(name=stretch_name(index), type=mujoco.mjtJoint.mjJNT_SLIDE, axis=(1.0, 0.0, 0.0),
                           stiffness=k, damping=k * params.damping_time_s,
                           armature=params.stretch_armature_ratio * params.mass_kg)
        if params.joints == "ball":
            stiffness = scale * params.bending_stiffness_nm2 / ds
            body.add_joint(
                name=joint_name(index, j),
                type=mujoco.mjtJoint.mjJNT_BALL,
                stiffness=stiffness,
                damping=stiffness * params.damping_time_s,
                armature=armature,
            )
            joints.append((joint_name(index, j),))
        else:
            for kind, axis in zip(HINGE_KINDS, np.eye(3)):
                stiffness = scale * hinge_stiffness[kind]
                body.add_joint(
                    name=hinge_name(index, j, kind),
                    type=mujoco.mjtJoint.mjJNT_HINGE,
                    axis=tuple(axis),
                    stiffness=stiffness,
                    damping=stiffness * params.damping_time_s,
                    armature=armature if bending_armature or kind == "twist" else 0.0,
                )
            joints.append(tuple(hinge_name(index, j, kind) for kind in HINGE_KINDS))
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
    return FilamentHandle(index, params.joints, tuple(bodies), tuple(geoms), tuple(joints))


def rest_quaternions(n_segments: int, ds: float, darboux: np.ndarray) -> np.ndarray:
    """(n, 4) spring reference quaternions for a uniform Darboux vector (tau, k1, k2), 1/m.

    The clamp joint (index 0) carries half the rotation, matching its half Voronoi length.
    """
    out = np.empty((n_segments, 4))
    out[0] = rest_rotation_quat(darboux, ds / 2)
    out[1:] = rest_rotation_quat(darboux, ds)
    return out


def _quat_rotate(quat: np.ndarray, vec: np.ndarray) -> np.ndarray:
    out = np.empty(3)
    mujoco.mju_rotVecQuat(out, np.asarray(vec, dtype=float), quat)
    return out


def _quat_inverse(quat: np.ndarray) -> np.ndarray:
    return np.array([quat[0], -quat[1], -quat[2], -quat[3]])


def _hinge_quat(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Quaternion of hinges about `axes` (k, 3), each in the frame left by the ones before, at `angles` (k,)."""
    quat, step = np.array([1.0, 0.0, 0.0, 0.0]), np.empty(4)
    for axis, angle in zip(axes, angles):
        mujoco.mju_axisAngle2Quat(step, axis, float(angle))
        mujoco.mju_mulQuat(quat, quat.copy(), step)
    return quat


def _hinge_chain(triad: np.ndarray, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quaternion of three hinges applied in turn and their axes in the successive joint frames.

    `triad` (3, 3) holds the physical axes (parent frame, HINGE_KINDS order) that the hinges must turn about
    at `angles`; each axis is expressed in the frame left by the hinges before it.
    """
    axes = np.empty((3, 3))
    for k in range(3):
        axes[k] = _quat_rotate(_quat_inverse(_hinge_quat(axes[:k], angles[:k])), triad[k])
    return _hinge_quat(axes, angles), axes


def rest_hinges(darboux: np.ndarray, ds: float, bend_axis: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """Hinge axes (2, 3, 3) and rest angles (2, 3), rad, of the clamp and of an interior joint.

    The rest rotation is exp(portion [Omega]x) with Omega = `darboux` (tau, k1, k2), 1/m, and portion ds / 2
    for the clamp, ds for the others. The axes are the material triad at the joint's mid-point (twist about
    the mid-tangent, out-of-plane normal, curl axis), so that the hinge springs measure the rod's own twist
    and bending there; `bend_axis` (unit, normal to x) is the curl axis to use when the rest shape is
    straight (default z). Without rest twist the angles are (0, 0, kappa portion); with it, they are solved
    so that the three hinges reproduce the rest rotation exactly.
    """
    darboux = np.asarray(darboux, dtype=float)
    tau, kappa = darboux[0], math.hypot(darboux[1], darboux[2])
    if kappa > 0:
        curl = np.array([0.0, darboux[1], darboux[2]]) / kappa
    else:
        curl = np.array([0.0, 0.0, 1.0]) if bend_axis is None else np.asarray(bend_axis, dtype=float)
    axes, angles = np.empty((2, 3, 3)), np.empty((2, 3))
    for j, portion in enumerate((ds / 2, ds)):
        half = np.empty(4)
        mujoco.mju_axisAngle2Quat(half, curl, kappa * portion / 2)
        tangent = _quat_rotate(half, np.array([1.0, 0.0, 0.0]))
        triad = np.stack([tangent, np.cross(tangent, curl), curl])
        guess = np.array([tau * portion, 0.0, kappa * portion])
        if tau != 0.0:
            target = rest_rotation_quat(darboux, portion)

            def residual(theta: np.ndarray, triad=triad, target=target) -> np.ndarray:
                quat = _hinge_chain(triad, theta)[0]
                return quat * np.sign(quat @ target) - target

            guess = least_squares(residual, guess, xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        angles[j] = guess
        axes[j] = _hinge_chain(triad, guess)[1]
    return axes, angles


def hinge_rest_angles(axes: np.ndarray, darboux: np.ndarray, ds: float) -> np.ndarray:
    """Rest angles (2, 3), rad, that make hinges of fixed `axes` (2, 3, 3) (clamp, interior) reproduce `darboux`.

    The rest rotation is exp(portion [Omega]x), portion ds / 2 (clamp) or ds; for a curl about the hinges'
    own curl axis the angles are (tau portion, 0, kappa portion) exactly, otherwise they are solved.
    """
    darboux = np.asarray(darboux, dtype=float)
    kappa = math.hypot(darboux[1], darboux[2])
    angles = np.empty((2, 3))
    for j, portion in enumerate((ds / 2, ds)):
        target = rest_rotation_quat(darboux, portion)

        def residual(theta: np.ndarray, axes=axes[j], target=target) -> np.ndarray:
            quat = _hinge_quat(axes, theta)
            return quat * np.sign(quat @ target) - target

        guess = np.array([darboux[0] * portion, 0.0, kappa * portion])
        if np.max(np.abs(residual(guess))) > 1e-12:
            guess = least_squares(residual, guess, xtol=1e-15, ftol=1e-15, gtol=1e-15).x
        angles[j] = guess
    return angles


@dataclass(frozen=True, eq=False)
class ChainJoints:
    """Compiled joint indices of filaments that share a joint model: writes rest shapes and perturbations."""

    joints: JointModel
    ids: np.ndarray
    """(F, n, k) joint ids, root to tip; k = 1 (ball) or 3 (hinges, HINGE_KINDS order)."""
    qpos: np.ndarray
    """(F, n, 4) quaternion or (F, n, 3) hinge-angle indices into qpos / qpos_spring."""

    @classmethod
    def bind(cls, model: mujoco.MjModel, handles: list[FilamentHandle]) -> ChainJoints:
        """Resolve the joints of `handles` (all of one joint model) in a compiled model."""
        kinds = {h.joints for h in handles}
        if len(kinds) != 1:
            raise ParameterError(f"filaments of one chain set must share a joint model, got {sorted(kinds)}")
        return cls(
            kinds.pop(),
            np.stack([h.joint_ids(model) for h in handles]),
            np.stack([h.qpos_addresses(model) for h in handles]),
        )

    def set_rest(self, model: mujoco.MjModel, darboux: np.ndarray, ds: float, bend_axes: np.ndarray) -> None:
        """Write each filament's rest shape: Darboux vector (F, 3) (tau, k1, k2), 1/m, segment length ds, m.

        `bend_axes` (F, 3): each filament's curl axis (unit, normal to x), used by hinges while straight.
        """
        darboux = np.atleast_2d(np.asarray(darboux, dtype=float))
        if self.joints == "ball":
            model.qpos_spring[self.qpos] = np.stack(
                [rest_quaternions(self.ids.shape[1], ds, w) for w in darboux]
            )
            return
        for f, (w, axis) in enumerate(zip(darboux, np.atleast_2d(bend_axes))):
            axes, angles = rest_hinges(w, ds, axis)
            model.jnt_axis[self.ids[f, 0]] = axes[0]
            model.jnt_axis[self.ids[f, 1:]] = axes[1]
            model.qpos_spring[self.qpos[f, 0]] = angles[0]
            model.qpos_spring[self.qpos[f, 1:]] = angles[1]

    def set_rest_uniform(
        self,
        model: mujoco.MjModel,
        curvature_per_m: float,
        twist_per_m: float,
        ds: float,
        bend_axes: np.ndarray,
        axes: np.ndarray | None = None,
    ) -> None:
        """Rest shapes of filaments that differ only in their curl axes `bend_axes` (F, 3), unit, normal to x.

        Darboux vector tau x + kappa axis (1/m) per filament; the hinges' rest angles are shared and their axes
        turned about x from one solution (`set_rest` solves every filament). `axes` (2, 3, 3), the hinge axes
        (clamp, interior) of a curl about z as `rest_hinges` returns them, fixes the axes and solves only the
        angles: an actuation that rewrote the axes at every pressure step would move every segment whose
        hinges are off their rest angles (twisted or bent in contact) without a velocity, a kinematic jump of
        up to millimetres at the tips per step. Default: the axes of the rest shape itself.
        """
        bend_axes = np.atleast_2d(np.asarray(bend_axes, dtype=float))
        darboux = curvature_per_m * bend_axes
        darboux[:, 0] += twist_per_m
        if self.joints == "ball":
            self.set_rest(model, darboux, ds, bend_axes)
            return
        shape = np.array([twist_per_m, 0.0, curvature_per_m])
        if axes is None:
            axes, angles = rest_hinges(shape, ds)
        else:
            angles = hinge_rest_angles(axes, shape, ds)
        for f, axis in enumerate(bend_axes):
            alpha = math.atan2(-axis[1], axis[2])  # rotation about x taking z onto the curl axis
            cos, sin = math.cos(alpha), math.sin(alpha)
            turn = np.array([[1.0, 0.0, 0.0], [0.0, cos, -sin], [0.0, sin, cos]])
            model.jnt_axis[self.ids[f, 0]] = axes[0] @ turn.T
            model.jnt_axis[self.ids[f, 1:]] = axes[1] @ turn.T
            model.qpos_spring[self.qpos[f, 0]] = angles[0]
            model.qpos_spring[self.qpos[f, 1:]] = angles[1]

    def perturb(self, data: mujoco.MjData, rng: np.random.Generator, sigma_rad: float) -> None:
        """Set every joint to a random rotation of standard deviation `sigma_rad` (rad) per axis."""
        if self.joints == "hinges":
            data.qpos[self.qpos] = rng.normal(0.0, sigma_rad, size=self.qpos.shape)
            return
        quat = np.empty(4)
        for row, vec in zip(self.qpos.reshape(-1, 4), rng.normal(0.0, sigma_rad, size=(self.qpos[..., 0].size, 3))):
            angle = float(np.linalg.norm(vec))
            mujoco.mju_axisAngle2Quat(quat, vec / (angle + 1e-300), angle)
            data.qpos[row] = quat  # `row` is an index array: data.qpos[row] would be a copy
