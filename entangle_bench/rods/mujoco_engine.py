"""The harness's own filament (`entangle_bench.filament`) as a clamped rod, and the relaxation that brings any rod
representation to a stable static equilibrium (`representations.solve_representation`).

The rod is built with exactly the builder the gripper uses (joint model "hinges": twist, out-of-plane and
in-plane hinges per segment; "ball": one isotropic ball joint), clamped at the case's base frame, started in
its rest shape, and relaxed with dynamic relaxation (kinetic damping) until every body is at rest. It has
nothing to touch, so it compiles with collision off.

Equilibrium branch: dynamic relaxation preserves symmetry, so a planar rod started exactly in its plane can
come to rest on an unstable planar equilibrium (a saddle: curl_hanging with 14-16 or 32 segments stops on a
branch 0.1 L away from the stable one, with a force residual of 1e-11 N m). `relax_to_stable_equilibrium`
therefore checks every rest state for stability (the eigenvalues of the finite-difference stiffness matrix)
and pushes a saddle along its unstable mode, both ways, keeping the lower-energy rest state.
"""

from __future__ import annotations

import mujoco
import numpy as np

from entangle_bench.effects import NO_CONTACT, apply_effects
from entangle_bench.filament import ChainJoints, FilamentParams, JointModel, add_filament
from entangle_bench.presets import Numerics
from entangle_bench.rods.case import RodCase
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
    case: RodCase,
    n_segments: int,
    damping_time_s: float = STATICS_DAMPING_TIME_S,
    joints: JointModel | None = None,
) -> FilamentParams:
    """A solid filament with the case's geometry and material; joint damping time `damping_time_s` (s).

    `joints`: the joint model ("hinges" or "ball"); None keeps the filament default.
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
        **({} if joints is None else {"joints": joints}),
    )


def build_rod(
    case: RodCase,
    n_segments: int,
    numerics: Numerics,
    damping_time_s: float = STATICS_DAMPING_TIME_S,
    joints: JointModel | None = None,
) -> tuple[mujoco.MjModel, ChainJoints, list[str]]:
    """Compile the clamped rod in its rest shape; return the model, its joints and body names.

    `damping_time_s` (s) is the joints' Kelvin-Voigt relaxation time (statics default: 0.2 s). The springs'
    references hold the case's rest shape; the state is still straight. `joints` picks the joint model
    ("hinges" or "ball"; default: the filament default).
    """
    spec = mujoco.MjSpec()
    numerics.apply(spec)
    spec.option.gravity = case.gravity
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, case.base_frame.flatten())
    handle = add_filament(
        spec.worldbody,
        filament_params(case, n_segments, damping_time_s, joints),
        0,
        pos=case.base_position,
        quat=tuple(quat),
        twist_armature_scale=numerics.twist_armature_scale,
        bending_armature=numerics.bending_armature,
    )
    apply_effects(spec, NO_CONTACT, {}, [list(handle.body_names)], np.zeros((1, 2)), case.length)
    model = spec.compile()
    chain = ChainJoints.bind(model, [handle])
    chain.set_rest(model, case.darboux, case.length / n_segments, np.array([0.0, 0.0, 1.0]))
    return model, chain, list(handle.body_names)


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
    equilibrium (a saddle). The state is then pushed PERTURBATION_RAD (largest dof) along that mode both ways,
    each push relaxed to a stable state, and the one of lower potential energy kept: which side of a saddle
    the nearest minimum lies on depends on the discretization, the energy does not. `length` (m) scales the
    rest speed 1e-6 L / 0.3 m/s; `max_time_s` (simulated s) bounds each relaxation.
    """
    speed_tol = 1e-6 * length / 0.3
    if not step_until_rest(model, data, max_time_s, speed_tol_m_s=speed_tol, kinetic_damping=True):
        return False, 0
    values, vectors = np.linalg.eigh(stiffness_matrix(model, data))
    if values[0] >= -NEGATIVE_STIFFNESS_TOL * np.max(np.abs(values)):
        return True, 0
    saddle = data.qpos.copy()
    mode = vectors[:, 0] / np.max(np.abs(vectors[:, 0]))
    best: tuple[float, np.ndarray, float, int] | None = None
    for sign in (1.0, -1.0):
        data.qpos[:] = saddle
        data.qvel[:] = 0.0
        mujoco.mj_integratePos(model, data.qpos, sign * PERTURBATION_RAD * mode, 1.0)
        settled, left = _relax_pushed(model, data, speed_tol, max_time_s)
        if settled:
            mujoco.mj_forward(model, data)
            mujoco.mj_energyPos(model, data)
            energy = float(data.energy[0])
            if best is None or energy < best[0]:
                best = (energy, data.qpos.copy(), data.time, left)
    if best is None:
        return False, MAX_STABILITY_CHECKS
    data.qpos[:] = best[1]
    data.qvel[:] = 0.0
    data.time = best[2]
    mujoco.mj_forward(model, data)
    return True, 1 + best[3]


def _relax_pushed(
    model: mujoco.MjModel, data: mujoco.MjData, speed_tol: float, max_time_s: float
) -> tuple[bool, int]:
    """Relax a state pushed off a saddle, pushing again along new unstable modes; (settled, saddles left)."""
    for saddles in range(MAX_STABILITY_CHECKS):
        if not step_until_rest(model, data, max_time_s, speed_tol_m_s=speed_tol, kinetic_damping=True):
            return False, saddles
        values, vectors = np.linalg.eigh(stiffness_matrix(model, data))
        if values[0] >= -NEGATIVE_STIFFNESS_TOL * np.max(np.abs(values)):
            return True, saddles
        mode = vectors[:, 0] / np.max(np.abs(vectors[:, 0]))
        mujoco.mj_integratePos(model, data.qpos, PERTURBATION_RAD * mode, 1.0)
        data.qvel[:] = 0.0
    return False, MAX_STABILITY_CHECKS
