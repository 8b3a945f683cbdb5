"""Alternative MuJoCo filament representations, for the accuracy-time study only.

The harness filament is `ball` (`entangle_bench.filament`: capsule chain, one isotropic ball-joint spring
per vertex, so its twist stiffness is E I / ds instead of G J / ds). The alternatives:

* `ball_twist`: the harness chain plus, in each body, a twist hinge about the tangent placed in series with
  the ball joint. Springs in series add compliances, so a hinge of stiffness
  k_h = 1 / (ds (1 / GJ - 1 / EI)) makes the twist stiffness G J / ds while bending stays E I / ds (exact
  for small per-joint twist; needs G J < E I, i.e. nu > 0; for nu = 0 it is the plain chain). Plugin-free,
  one more degree of freedom per segment.
* `cable`: MuJoCo's composite cable (`<composite type="cable">`) with the first-party
  `mujoco.elasticity.cable` plugin (config `twist` = G and `bend` = E in Pa; the plugin takes J and I from
  the capsule radius), a discrete Cosserat rod with anisotropic bending/twist stiffness (MuJoCo
  plugin/elasticity/cable.cc). The rest shape is the model's reference configuration (body quaternions).
* `flex1d`: a 1D `flexcomp` with MuJoCo 3.17's 1D flex elasticity ("twist-free isotropic discrete elastic
  rod", section circle of the flex radius, release notes of 3.17.0), hard edge equality constraints for
  inextensibility, integrated with the `discrete` integrator. It needs a straight reference configuration,
  so it cannot represent rest curvature or twist, and its vertex spacing must exceed the diameter.

Clamp placement: `ball` and `ball_twist` clamp with the half-length joint at the base (second order, see
`filament.py`). `cable` and `flex1d` fix a first segment (body or edge) whose midpoint is the base point and
whose direction is the base tangent, as the PyElastica reference does; the segment length is then
h = L / (n - 1/2). Every representation is brought to equilibrium with the same dynamic relaxation
(`mujoco_engine.relax_to_stable_equilibrium`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.config import check_range
from entangle_bench.errors import ParameterError
from entangle_bench.filament import ChainJoints, rest_quaternions, rest_rotation_quat
from entangle_bench.presets import DEFAULT_PRESET, Numerics, get_preset
from entangle_bench.registry import Registry
from entangle_bench.rods import mujoco_engine
from entangle_bench.rods.case import RodCase, RodResult, resample_centerline
from entangle_bench.scene import step_until_rest

#: (case, n_segments, numerics, damping_time_s) -> RodModel, by representation name.
Builder = Callable[[RodCase, int, Numerics, float], "RodModel"]
REPRESENTATIONS: Registry[Builder] = Registry("representation")


@dataclass
class RodModel:
    """A compiled clamped rod in its rest shape, with a function giving its centerline (m)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    vertices: Callable[[mujoco.MjData], np.ndarray]
    """Centerline polyline (k, 3) in m from base to tip."""
    representation: str
    n_segments: int
    integrator: str
    """The integrator actually used (`flex1d` always uses `discrete`)."""
    joints: ChainJoints | None = None
    """The harness chain's joints, whose springs' references set the rest shape (the actuation); None where
    the rest shape is fixed when the model is made (`cable`, `flex1d`, `ball_twist`)."""


def _base_quat(case: RodCase) -> tuple[float, float, float, float]:
    """Quaternion of the clamp frame (t, d1, d2)."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, case.base_frame.flatten())
    return tuple(quat)


def _segment_inertia(case: RodCase, ds: float) -> tuple[float, float, float]:
    """Mass (kg) and the axial and transverse moments of inertia (kg m^2) of a solid segment of length ds."""
    mass = case.line_density * ds
    return mass, 0.5 * mass * case.radius**2, mass * (ds**2 / 12.0 + case.radius**2 / 4.0)


def _chain_vertices(ids: list[int], ds: float, skip_half_first: bool) -> Callable[[mujoco.MjData], np.ndarray]:
    """Centerline of a body chain along local x: body origins then the tip; optionally from mid-body 0."""

    def vertices(data: mujoco.MjData) -> np.ndarray:
        tip = data.xpos[ids[-1]] + ds * data.xmat[ids[-1]].reshape(3, 3)[:, 0]
        points = np.vstack([data.xpos[ids], tip])
        if skip_half_first:
            points[0] = data.xpos[ids[0]] + 0.5 * ds * data.xmat[ids[0]].reshape(3, 3)[:, 0]
        return points

    return vertices


@REPRESENTATIONS.register("ball", tags=("harness",))
def _build_ball(case: RodCase, n: int, numerics: Numerics, damping_time_s: float) -> RodModel:
    """The harness filament (`mujoco_engine.build_rod`) in its rest shape."""
    model, joints, bodies = mujoco_engine.build_rod(case, n, numerics, damping_time_s)
    data = mujoco.MjData(model)
    data.qpos[joints.qpos] = model.qpos_spring[joints.qpos]
    mujoco.mj_forward(model, data)
    ids = [model.body(b).id for b in bodies]
    vertices = _chain_vertices(ids, case.length / n, False)
    return RodModel(model, data, vertices, "ball", n, numerics.integrator, joints)


def series_twist_stiffness(case: RodCase, ds: float) -> float:
    """Stiffness (N m/rad) of the twist hinge in series with a ball joint of E I / ds: 1/(ds (1/GJ - 1/EI))."""
    gj, ei = case.twist_stiffness, case.bending_stiffness
    if gj > ei * (1.0 + 1e-12):
        raise ParameterError(
            f"ball_twist needs G J <= E I (poisson_ratio >= 0); case {case.name!r} has "
            f"poisson_ratio = {case.poisson_ratio}"
        )
    if gj >= ei:
        return float("inf")
    return 1.0 / (ds * (1.0 / gj - 1.0 / ei))


@REPRESENTATIONS.register("ball_twist")
def _build_ball_twist(case: RodCase, n: int, numerics: Numerics, damping_time_s: float) -> RodModel:
    """Harness-like ball chain with a series twist hinge in every body (see module docstring)."""
    ds = case.length / n
    k_bend = case.bending_stiffness / ds
    k_twist = series_twist_stiffness(case, ds)
    mass, i_axial, i_trans = _segment_inertia(case, ds)
    armature = (numerics.twist_armature_scale - 1.0) * i_axial
    spec = mujoco.MjSpec()
    numerics.apply(spec)
    spec.option.gravity = case.gravity
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    body = spec.worldbody
    names = []
    for j in range(n):
        scale = 2.0 if j == 0 else 1.0
        body = body.add_body(
            name=f"b{j:03d}",
            pos=case.base_position if j == 0 else (ds, 0.0, 0.0),
            quat=_base_quat(case) if j == 0 else (1.0, 0.0, 0.0, 0.0),
            mass=mass,
            ipos=(ds / 2, 0.0, 0.0),
            inertia=(i_axial, i_trans, i_trans),
            explicitinertial=True,
        )
        if np.isfinite(k_twist):
            # Twist about the rest mid-tangent between the two segments: half the rest rotation.
            half = rest_rotation_quat(case.darboux, 0.25 * ds if j == 0 else 0.5 * ds)
            axis = np.empty(3)
            mujoco.mju_rotVecQuat(axis, np.array([1.0, 0.0, 0.0]), half)
            body.add_joint(
                name=f"t{j:03d}",
                type=mujoco.mjtJoint.mjJNT_HINGE,
                axis=tuple(axis),
                stiffness=scale * k_twist,
                damping=scale * k_twist * damping_time_s,
                armature=max(armature, i_axial),
            )
        body.add_joint(
            name=f"j{j:03d}",
            type=mujoco.mjtJoint.mjJNT_BALL,
            stiffness=scale * k_bend,
            damping=scale * k_bend * damping_time_s,
            armature=armature,
        )
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=(0.0, 0.0, 0.0, ds, 0.0, 0.0),
            size=(case.radius, 0.0, 0.0),
            mass=0.0,
        )
        names.append(f"b{j:03d}")
    model = spec.compile()
    adr = np.array([model.joint(f"j{j:03d}").qposadr[0] for j in range(n)])[:, None] + np.arange(4)
    rest = rest_quaternions(n, ds, case.darboux)
    model.qpos_spring[adr] = rest
    data = mujoco.MjData(model)
    data.qpos[adr] = rest
    mujoco.mj_forward(model, data)
    ids = [model.body(name).id for name in names]
    vertices = _chain_vertices(ids, ds, False)
    return RodModel(model, data, vertices, "ball_twist", n, numerics.integrator)


def _cable_xml(case: RodCase, n: int, h: float, damping: float) -> str:
    """MJCF of a straight composite cable with the elasticity plugin, inside a clamp body."""
    pos = " ".join(f"{v:.17g}" for v in case.base_position)
    quat = " ".join(f"{v:.17g}" for v in _base_quat(case))
    return f"""<mujoco>
  <extension><plugin plugin="mujoco.elasticity.cable"/></extension>
  <worldbody>
    <body name="clamp" pos="{pos}" quat="{quat}">
      <composite prefix="c" type="cable" curve="s" count="{n + 1} 1 1" size="{n * h:.17g}"
                 offset="{-h / 2:.17g} 0 0" initial="none">
        <plugin plugin="mujoco.elasticity.cable">
          <config key="twist" value="{case.shear_modulus:.17g}"/>
          <config key="bend" value="{case.youngs_modulus:.17g}"/>
          <config key="vmax" value="0"/>
        </plugin>
        <joint kind="main" damping="{damping:.17g}"/>
        <geom type="capsule" size="{case.radius:.17g}" density="{case.density:.17g}"/>
      </composite>
    </body>
  </worldbody>
</mujoco>"""


@REPRESENTATIONS.register("cable")
def _build_cable(case: RodCase, n: int, numerics: Numerics, damping_time_s: float) -> RodModel:
    """Composite cable with the elasticity plugin, rest shape in the body quaternions."""
    h = case.length / (n - 0.5)
    damping = case.bending_stiffness / h * damping_time_s
    spec = mujoco.MjSpec.from_string(_cable_xml(case, n, h, damping))
    numerics.apply(spec)
    spec.option.gravity = case.gravity
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    bodies = [b for b in spec.bodies if b.name.startswith("cB")]
    if len(bodies) != n:
        raise ParameterError(f"cable composite made {len(bodies)} bodies, expected {n}")
    mass, i_axial, i_trans = _segment_inertia(case, h)
    rest = rest_rotation_quat(case.darboux, h)
    for j, body in enumerate(bodies):
        body.pos = (-h / 2, 0.0, 0.0) if j == 0 else (h, 0.0, 0.0)
        body.quat = (1.0, 0.0, 0.0, 0.0) if j == 0 else tuple(rest)
        body.mass, body.ipos, body.inertia = mass, (h / 2, 0.0, 0.0), (i_axial, i_trans, i_trans)
        body.explicitinertial = True
        for geom in body.geoms:
            geom.fromto = (0.0, 0.0, 0.0, h, 0.0, 0.0)
        for joint in body.joints:
            joint.armature = (numerics.twist_armature_scale - 1.0) * i_axial
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ids = [model.body(b.name).id for b in bodies]
    return RodModel(model, data, _chain_vertices(ids, h, True), "cable", n, numerics.integrator)


@REPRESENTATIONS.register("flex1d")
def _build_flex1d(case: RodCase, n: int, numerics: Numerics, damping_time_s: float) -> RodModel:
    """1D flexcomp rod with bending elasticity, hard edge constraints and the `discrete` integrator."""
    if any(case.intrinsic_curvature) or case.intrinsic_twist:
        raise ParameterError(
            f"flex1d cannot represent case {case.name!r}: MuJoCo 3.17 1D flex elasticity needs a straight "
            "reference configuration (no intrinsic_curvature or intrinsic_twist)"
        )
    h = case.length / (n - 0.5)
    if h <= 2.0 * case.radius:
        raise ParameterError(
            f"flex1d with {n} segments: spacing {h:.4g} m must exceed the diameter {2 * case.radius:.4g} m "
            f"(at most {int(case.length / (2 * case.radius) + 0.5) - 1} segments for case {case.name!r})"
        )
    timeconst = max(2.0 * numerics.timestep_s, 1e-3)
    t = np.asarray(case.base_direction)
    center = np.asarray(case.base_position) + t * (-h / 2 + n * h / 2)
    pos = " ".join(f"{v:.17g}" for v in center)
    quat = " ".join(f"{v:.17g}" for v in _base_quat(case))
    xml = f"""<mujoco>
  <worldbody>
    <flexcomp name="rod" type="grid" dim="1" count="{n + 1} 1 1" spacing="{h:.17g} 1 1"
              pos="{pos}" quat="{quat}" radius="{case.radius:.17g}" mass="{case.line_density * h * (n + 1):.17g}">
      <elasticity young="{case.youngs_modulus:.17g}" poisson="{min(case.poisson_ratio, 0.49):.17g}"
                  damping="{damping_time_s:.17g}"/>
      <edge equality="true" solref="{timeconst:.17g} 1" solimp="0.99 0.999 0.001"/>
      <pin id="0 1"/>
      <contact contype="0" conaffinity="0"/>
    </flexcomp>
  </worldbody>
</mujoco>"""
    spec = mujoco.MjSpec.from_string(xml)
    numerics.apply(spec)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
    spec.option.gravity = case.gravity
    bodies = [b for b in spec.bodies if b.name.startswith("rod_")]
    for body in bodies:
        body.mass = case.line_density * h
    bodies[-1].mass = 0.5 * case.line_density * h  # lumped (Voronoi) mass of the free end
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)

    def vertices(d: mujoco.MjData) -> np.ndarray:
        points = d.flexvert_xpos.copy()
        points[0] = 0.5 * (points[0] + points[1])
        return points

    return RodModel(model, data, vertices, "flex1d", n, "discrete")


def build_representation(
    case: RodCase,
    representation: str,
    n_segments: int,
    numerics: Numerics,
    damping_time_s: float = mujoco_engine.STATICS_DAMPING_TIME_S,
) -> RodModel:
    """Compile `case` as `representation` with `n_segments` segments, started in its rest shape.

    `damping_time_s` (s) is the Kelvin-Voigt (Rayleigh) relaxation time of the bending/twist springs.
    """
    check_range("n_segments", n_segments, 2, 1000)
    check_range("damping_time_s", damping_time_s, 0.0, 10.0)
    return REPRESENTATIONS.get(representation)(case, int(n_segments), numerics, damping_time_s)


def solve_representation(
    case: RodCase,
    representation: str,
    n_segments: int | None = None,
    preset: str = DEFAULT_PRESET,
    numerics: Numerics | None = None,
    points: int = 201,
    max_time_s: float = 60.0,
) -> RodResult:
    """Static equilibrium of `case` with `representation`; centerline at `points` uniform-arclength points.

    Segments and numerics come from `preset` unless given. Statics use `implicitfast` (`flex1d`:
    `discrete`); `max_time_s` bounds each relaxation in simulated seconds. Rods with equality constraints
    (`flex1d`) skip the stability check, since constraint forces are not in the stiffness matrix.
    """
    chosen = get_preset(preset)
    n = n_segments or chosen.n_segments
    statics = dataclasses.replace(numerics or chosen.numerics, integrator="implicitfast")
    rod = build_representation(case, representation, n, statics)
    start = time.perf_counter()
    if rod.model.neq:
        speed = 1e-6 * case.length / 0.3
        settled = step_until_rest(rod.model, rod.data, max_time_s, speed_tol_m_s=speed, kinetic_damping=True)
        saddles = -1
    else:
        settled, saddles = mujoco_engine.relax_to_stable_equilibrium(
            rod.model, rod.data, case.length, max_time_s
        )
    wall = time.perf_counter() - start
    if not settled:
        raise ParameterError(
            f"rod case {case.name!r} as {representation} with {n} segments did not reach a stable "
            f"equilibrium within {max_time_s} s of simulated time per relaxation"
        )
    return RodResult(
        centerline=resample_centerline(rod.vertices(rod.data), points, method="linear"),
        engine="mujoco",
        wall_time_s=wall,
        settings={
            "preset": preset,
            "representation": representation,
            "n_segments": n,
            "timestep_s": statics.timestep_s,
            "integrator": rod.integrator,
            "sim_time_s": rod.data.time,
            "saddles_left": saddles,
        },
    )
