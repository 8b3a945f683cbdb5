"""The harness's own filament (`entangle_bench.filament`) brought to static equilibrium.

The rod is built with exactly the builder the gripper uses (ball-joint chain with a series twist hinge per
segment; `twist_hinge=False` gives the plain, isotropic ball chain), clamped at the case's base frame,
started in its rest shape, and relaxed with dynamic relaxation (kinetic damping) until every body is at
rest. It has nothing to touch, so it compiles with collision off.

Equilibrium branch: dynamic relaxation preserves symmetry, so a planar rod started exactly in its plane can
come to rest on an unstable planar equilibrium (a saddle: curl_hanging with 14-16 or 32 segments stops on a
branch 0.1 L away from the stable one, with a force residual of 1e-11 N m). `relax_to_stable_equilibrium`
therefore checks every rest state for stability (the eigenvalues of the finite-difference stiffness matrix)
and pushes a saddle along its unstable mode before relaxing again.
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np

from entangle_bench.effects import NO_CONTACT, apply_effects
from entangle_bench.errors import ParameterError
from entangle_bench.filament import FilamentParams, add_filament, rest_quaternions, rest_twist_axes
from entangle_bench.presets import Numerics, get_preset
from entangle_bench.rods.case import RodCase, RodResult, resample_centerline
from entangle_bench.scene import step_until_rest

#: Statics need no realistic damping: a long relaxation time with implicit damping settles fastest.
STATICS_DAMPING_TIME_S = 0.2

#: Push (rad, largest degree of freedom) along an unstable mode to leave a saddle.
PERTURBATION_RAD = 1e-2

#: An eigenvalue of the stiffness matrix below -this x its largest |eigenvalue| marks a saddle.
NEGATIVE_STIFFNESS_TOL = 1e-9

#: Largest number of saddles left before giving up.
MAX_STABILITY_CHECKS = 4


def filament_params(
    case: RodCase, n_segments: int, damping_time_s: float = STATICS_DAMPING_TIME_S, twist_hinge: bool = True
) -> FilamentParams:
    """A solid filament with the case's geometry and material; joint damping time `damping_time_s` (s).

    `twist_hinge` False gives the plain ball chain (twist stiffness E I instead of G J).
    """
    return FilamentParams(
        length_m=case.length,
        outer_radius_m=case.radius,
        channel_radius_ratio=0.0,
        channel_eccentricity=0.0,
        youngs_modulus_pa=case.youngs_modulus,
        poisson_ratio=case.poisson_ratio,
        density_kg_m3=case.density,
        n_segments=n_segments,
        damping_time_s=damping_time_s,
        twist_hinge=twist_hinge,
    )


def build_rod(
    case: RodCase,
    n_segments: int,
    numerics: Numerics,
    damping_time_s: float = STATICS_DAMPING_TIME_S,
    twist_hinge: bool = True,
) -> tuple[mujoco.MjModel, np.ndarray, list[str]]:
    """Compile the clamped rod; return the model, its ball joints' qpos addresses (n, 4) and body names.

    `damping_time_s` (s) is the joints' Kelvin-Voigt relaxation time (statics default: 0.2 s); `twist_hinge`
    False builds the plain ball chain. The twist hinges' axes are set to the rest mid-tangents.
    """
    spec = mujoco.MjSpec()
    numerics.apply(spec)
    spec.option.gravity = case.gravity
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, case.base_frame.flatten())
    handle = add_filament(
        spec.worldbody,
        filament_params(case, n_segments, damping_time_s, twist_hinge),
        0,
        pos=case.base_position,
        quat=tuple(quat),
        twist_armature_scale=numerics.twist_armature_scale,
    )
    apply_effects(spec, NO_CONTACT, {}, [list(handle.body_names)], np.zeros((1, 2)), case.length)
    model = spec.compile()
    if handle.twist_names:
        model.jnt_axis[handle.twist_ids(model)] = rest_twist_axes(n_segments, case.length / n_segments, case.darboux)
    return model, handle.qpos_addresses(model), list(handle.body_names)


def stiffness_matrix(model: mujoco.MjModel, data: mujoco.MjData, step: float = 1e-6) -> np.ndarray:
    """Symmetric generalized stiffness -d(qfrc_passive - qfrc_bias)/dq (nv, nv) at rest, N m/rad or N/m.

    Central differences with `step` (rad or m) per degree of freedom, velocities zero; `data` is left at
    its original state.
    """
    qpos0 = data.qpos.copy()
    data.qvel[:] = 0.0
    columns = []
    for j in range(model.nv):
        forces = []
        for sign in (1.0, -1.0):
            direction = np.zeros(model.nv)
            direction[j] = sign * step
            data.qpos[:] = qpos0
            mujoco.mj_integratePos(model, data.qpos, direction, 1.0)
            mujoco.mj_forward(model, data)
            forces.append(data.qfrc_passive - data.qfrc_bias)
        columns.append(-(forces[0] - forces[1]) / (2.0 * step))
    data.qpos[:] = qpos0
    mujoco.mj_forward(model, data)
    stiffness = np.column_stack(columns)
    return 0.5 * (stiffness + stiffness.T)


def relax_to_stable_equilibrium(
    model: mujoco.MjModel, data: mujoco.MjData, length: float, max_time_s: float
) -> tuple[bool, int]:
    """Dynamic relaxation to a stable rest state; return (settled, number of saddles left).

    After each rest the generalized stiffness matrix is checked: a negative eigenvalue means an unstable
    equilibrium (a saddle), so the state is pushed PERTURBATION_RAD (largest dof) along that mode and
    relaxed again. `length` (m) scales the rest speed 1e-6 L / 0.3 m/s; `max_time_s` (simulated s)
    bounds each relaxation.
    """
    speed_tol = 1e-6 * length / 0.3
    for saddles in range(MAX_STABILITY_CHECKS + 1):
        if not step_until_rest(model, data, max_time_s, speed_tol_m_s=speed_tol, kinetic_damping=True):
            return False, saddles
        values, vectors = np.linalg.eigh(stiffness_matrix(model, data))
        if values[0] >= -NEGATIVE_STIFFNESS_TOL * np.max(np.abs(values)):
            return True, saddles
        mode = vectors[:, 0] / np.max(np.abs(vectors[:, 0]))
        mujoco.mj_integratePos(model, data.qpos, PERTURBATION_RAD * mode, 1.0)
        data.qvel[:] = 0.0
    return False, MAX_STABILITY_CHECKS


def solve_mujoco(
    case: RodCase,
    preset: str = "balanced",
    n_segments: int | None = None,
    numerics: Numerics | None = None,
    points: int = 201,
    max_time_s: float = 60.0,
    twist_hinge: bool = True,
) -> RodResult:
    """Static equilibrium of `case` with the harness filament; centerline at `points` uniform-arclength points.

    The preset sets segments and numerics; `n_segments`/`numerics` override them. Statics always use
    implicit damping (`implicitfast`) so the long relaxation time is stable. `max_time_s` bounds each
    relaxation in simulated seconds. `twist_hinge` False solves the plain (isotropic) ball chain.
    """
    chosen = get_preset(preset)
    n = n_segments or chosen.n_segments
    numerics = numerics or chosen.numerics
    statics = dataclasses.replace(numerics, integrator="implicitfast")
    model, adr, bodies = build_rod(case, n, statics, twist_hinge=twist_hinge)
    ds = case.length / n
    rest = rest_quaternions(n, ds, case.darboux)
    model.qpos_spring[adr] = rest
    data = mujoco.MjData(model)
    data.qpos[adr] = rest
    ids = [model.body(b).id for b in bodies]

    def vertices(d: mujoco.MjData) -> np.ndarray:
        tip = d.xpos[ids[-1]] + ds * d.xmat[ids[-1]].reshape(3, 3)[:, 0]
        return np.vstack([d.xpos[ids], tip])

    start = time.perf_counter()
    settled, saddles = relax_to_stable_equilibrium(model, data, case.length, max_time_s)
    wall = time.perf_counter() - start
    if not settled:
        raise ParameterError(
            f"rod case {case.name!r} did not reach a stable static equilibrium within {max_time_s} s of "
            f"simulated time per relaxation with {n} segments and dt = {statics.timestep_s} s"
        )
    return RodResult(
        centerline=resample_centerline(vertices(data), points, method="linear"),
        engine="mujoco",
        wall_time_s=wall,
        settings={
            "preset": preset,
            "representation": "ball" if twist_hinge else "ball_isotropic",
            "n_segments": n,
            "timestep_s": statics.timestep_s,
            "integrator": statics.integrator,
            "sim_time_s": data.time,
            "saddles_left": saddles,
        },
    )
