"""Numerical stability: a watchdog probe of filaments actuating in air, and the measured stable envelope.

`probe` runs a gripper (no object) hanging from a fixed hub: random joint perturbations, a pressure ramp to
the configured pressure, a hold, all under the runtime watchdog with bounds scaled to the gripper's own
energy. `scripts/stability_map.py` sweeps it over Young's modulus x timestep x segments for every
integrator (results/stability/); its boundary is recorded in ENVELOPE below, and `envelope_warnings`
compares a resolved configuration against it before a run.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench import effects as fx
from entangle_bench.gripper import bending_angles
from entangle_bench.scene import SceneConfig, build_scene
from entangle_bench.watchdog import Watchdog, WatchdogLimits, WatchdogStats, WatchdogTripped

#: Effects of the probe: gravity and the rod alone, so only the integration of the rod can fail.
PROBE_EFFECTS = fx.NO_CONTACT


@dataclass(frozen=True)
class ProbeResult:
    """Outcome of one stability probe (SI units)."""

    stable: bool
    reason: str
    """Why the watchdog tripped ('' if stable)."""
    time_s: float
    """Simulated time reached (the trip time if unstable)."""
    stats: WatchdogStats
    wall_time_s: float


def actuation_energy_j(config: SceneConfig) -> float:
    """Bending energy 0.5 EI kappa^2 L of all filaments at full pressure, J (the watchdog's W_act)."""
    fil = config.gripper.filament
    kappa = fil.curvature_per_m(config.gripper.pressure_pa)
    return config.gripper.n_filaments * 0.5 * fil.bending_stiffness_nm2 * kappa**2 * fil.length_m


def probe_limits(config: SceneConfig) -> WatchdogLimits:
    """Watchdog bounds scaled to the gripper: energy slack 10 % of its actuation plus lifting energy."""
    fil = config.gripper.filament
    lift = config.gripper.n_filaments * fil.mass_kg * 9.81 * fil.length_m
    return WatchdogLimits(
        max_speed_m_s=10.0,
        max_penetration_m=2.0 * fil.outer_radius_m,
        energy_slack_j=0.1 * (actuation_energy_j(config) + lift),
    )


def probe(
    config: SceneConfig,
    duration_s: float = 1.0,
    ramp_time_s: float = 0.3,
    seed: int = 0,
    perturbation_rad: float = 0.05,
    check_every_s: float = 0.01,
    limits: WatchdogLimits | None = None,
) -> ProbeResult:
    """Run the gripper of `config` (object ignored) hanging at z = 0.5 m: ramp, hold, watchdog; s, rad."""
    config = dataclasses.replace(config, object_name=None, object_params=None)
    scene = build_scene(config, hub_pos=(0.0, 0.0, 0.5))
    model = scene.model
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    angles = bending_angles(config.gripper, rng)
    scene.gripper.set_pressure(model, 0.0, angles)
    for row in scene.gripper.spring_addresses.reshape(-1, 4):
        vec = rng.normal(0.0, perturbation_rad, size=3)
        angle = float(np.linalg.norm(vec))
        mujoco.mju_axisAngle2Quat(data.qpos[row], vec / (angle + 1e-300), angle)
    mujoco.mj_forward(model, data)
    watchdog = Watchdog(model, data, limits or probe_limits(config), actuation_energy_j(config))
    steps = max(1, round(check_every_s / model.opt.timestep))
    pressure = config.gripper.pressure_pa
    start = time.perf_counter()
    reason = ""
    try:
        while data.time < duration_s - 1e-9:
            fraction = min(1.0, data.time / ramp_time_s) if ramp_time_s > 0 else 1.0
            scene.gripper.set_pressure(model, fraction * pressure, angles)
            mujoco.mj_step(model, data, nstep=steps)
            watchdog.check(model, data)
    except WatchdogTripped as exc:
        reason = exc.reason
    return ProbeResult(
        stable=not reason,
        reason=reason,
        time_s=float(data.time),
        stats=watchdog.stats,
        wall_time_s=time.perf_counter() - start,
    )


def coil_radius_m(config: SceneConfig) -> float:
    """Free coil radius 1 / kappa at the configured pressure, m (inf when unactuated)."""
    kappa = config.gripper.filament.curvature_per_m(config.gripper.pressure_pa)
    return math.inf if kappa == 0 else 1.0 / kappa
