"""The harness's own filament (ball-joint chain, `entangle_bench.filament`) brought to static equilibrium.

The rod is built with exactly the builder the gripper uses, clamped at the case's base frame, started in its
rest shape, and relaxed with dynamic relaxation (kinetic damping) until every body is at rest. It has
nothing to touch, so it compiles with collision off.
"""

from __future__ import annotations

import dataclasses
import time

import mujoco
import numpy as np

from entangle_bench.effects import Effects, apply_effects
from entangle_bench.errors import ParameterError
from entangle_bench.filament import FilamentParams, add_filament, rest_quaternions
from entangle_bench.presets import Numerics, get_preset
from entangle_bench.rods.case import RodCase, RodResult, resample_centerline
from entangle_bench.scene import step_until_rest

#: Statics need no realistic damping: a long relaxation time with implicit damping settles fastest.
STATICS_DAMPING_TIME_S = 0.2


def filament_params(case: RodCase, n_segments: int) -> FilamentParams:
    """A solid filament with the case's geometry and material."""
    return FilamentParams(
        length_m=case.length,
        outer_radius_m=case.radius,
        channel_radius_ratio=0.0,
        channel_eccentricity=0.0,
        youngs_modulus_pa=case.youngs_modulus,
        poisson_ratio=case.poisson_ratio,
        density_kg_m3=case.density,
        n_segments=n_segments,
        damping_time_s=STATICS_DAMPING_TIME_S,
    )


def build_rod(case: RodCase, n_segments: int, numerics: Numerics) -> tuple[mujoco.MjModel, np.ndarray, list[str]]:
    """Compile the clamped rod; return the model, its qpos addresses (n, 4) and body names."""
    spec = mujoco.MjSpec()
    numerics.apply(spec)
    spec.option.gravity = case.gravity
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, case.base_frame.flatten())
    handle = add_filament(
        spec.worldbody,
        filament_params(case, n_segments),
        0,
        pos=case.base_position,
        quat=tuple(quat),
        twist_armature_scale=numerics.twist_armature_scale,
    )
    nothing = Effects(
        filament_filament_contact=False,
        filament_self_contact=False,
        filament_object_contact=False,
        ground_contact=False,
    )
    apply_effects(spec, nothing, {}, [list(handle.body_names)], np.zeros((1, 2)), case.length)
    model = spec.compile()
    return model, handle.qpos_addresses(model), list(handle.body_names)


def solve_mujoco(
    case: RodCase,
    preset: str = "balanced",
    n_segments: int | None = None,
    numerics: Numerics | None = None,
    points: int = 201,
    max_time_s: float = 60.0,
) -> RodResult:
    """Static equilibrium of `case` with the harness filament; centerline at `points` uniform-arclength points.

    The preset sets segments and numerics; `n_segments`/`numerics` override them. Statics always use
    implicit damping (`implicitfast`) so the long relaxation time is stable.
    """
    chosen = get_preset(preset)
    n = n_segments or chosen.n_segments
    numerics = numerics or chosen.numerics
    statics = dataclasses.replace(numerics, integrator="implicitfast")
    model, adr, bodies = build_rod(case, n, statics)
    ds = case.length / n
    rest = rest_quaternions(n, ds, case.darboux)
    model.qpos_spring[adr] = rest
    data = mujoco.MjData(model)
    data.qpos[adr] = rest
    start = time.perf_counter()
    settled = step_until_rest(model, data, max_time_s, speed_tol_m_s=1e-6 * case.length / 0.3, kinetic_damping=True)
    wall = time.perf_counter() - start
    if not settled:
        raise ParameterError(
            f"rod case {case.name!r} did not reach static equilibrium within {max_time_s} s of simulated "
            f"time with {n} segments and dt = {statics.timestep_s} s (unstable or too slow)"
        )
    ids = [model.body(b).id for b in bodies]
    vertices = np.vstack([data.xpos[ids], data.xpos[ids[-1]] + ds * data.xmat[ids[-1]].reshape(3, 3)[:, 0]])
    return RodResult(
        centerline=resample_centerline(vertices, points, method="linear"),
        engine="mujoco",
        wall_time_s=wall,
        settings={
            "preset": preset,
            "n_segments": n,
            "timestep_s": statics.timestep_s,
            "integrator": statics.integrator,
            "sim_time_s": data.time,
        },
    )
