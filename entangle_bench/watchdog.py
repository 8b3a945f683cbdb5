"""Runtime watchdog: catches numerical trouble in a running trial so it is reported, never scored.

Checked after every control step: NaN/Inf in the state, MuJoCo's warning counters (bad qacc, contact
and constraint buffer overflow, bad inertia), mechanical energy beyond the work the harness can have
put in, penetration and body speed beyond set bounds. The watchdog also keeps the worst values it
has seen (`Watchdog.stats`), so stability tests can assert margins rather than only "did not trip".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from entangle_bench.config import check_range

WATCHED_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQACC: "bad_qacc",
    mujoco.mjtWarning.mjWARN_BADQVEL: "bad_qvel",
    mujoco.mjtWarning.mjWARN_BADQPOS: "bad_qpos",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "contact_overflow",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "constraint_overflow",
    mujoco.mjtWarning.mjWARN_INERTIA: "bad_inertia",
}


class WatchdogTripped(Exception):
    """A trial became numerically unstable; `reason` and `time_s` say how and when."""

    def __init__(self, reason: str, time_s: float):
        self.reason, self.time_s = reason, time_s
        super().__init__(f"{reason} at t = {time_s:.4f} s")


@dataclass(frozen=True)
class WatchdogLimits:
    """Bounds beyond which a trial counts as unstable (SI units)."""

    max_speed_m_s: float = 20.0
    """Largest speed of any body's center of mass, m/s (the hub moves at most 2 m/s)."""
    max_penetration_m: float = 0.005
    grace_time_s: float = 0.2
    """No penetration check for this long after the watchdog starts: initial overlaps resolve."""
    energy_slack_j: float = 0.05
    """Absolute allowance on top of the energy bound, J."""

    def __post_init__(self) -> None:
        check_range("watchdog.max_speed_m_s", self.max_speed_m_s, 0.0, None, low_open=True)
        check_range("watchdog.max_penetration_m", self.max_penetration_m, 0.0, None, low_open=True)
        check_range("watchdog.grace_time_s", self.grace_time_s, 0.0, None)
        check_range("watchdog.energy_slack_j", self.energy_slack_j, 0.0, None)


@dataclass
class WatchdogStats:
    """Worst values seen so far (SI units)."""

    checks: int = 0
    max_speed_m_s: float = 0.0
    max_penetration_m: float = 0.0
    """Deepest contact after the grace time, m (0 if nothing ever penetrated)."""
    max_energy_j: float = -math.inf
    min_energy_margin_j: float = math.inf
    """Smallest (bound - energy) seen, J; negative only in the check that tripped."""


def _gravity_on(model: mujoco.MjModel) -> bool:
    return not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY


def mechanical_energy(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """Potential (gravity, buoyancy, springs) plus kinetic energy, J.

    Buoyancy is modelled as gravity compensation (`body_gravcomp`, see `effects`), an upward force
    gravcomp * m * |g| at the center of mass, whose potential is + gravcomp * m * (g . x).
    """
    mujoco.mj_energyPos(model, data)
    mujoco.mj_energyVel(model, data)
    energy = float(data.energy[0] + data.energy[1])
    if model.ngravcomp and _gravity_on(model):
        lift = model.body_gravcomp * model.body_mass
        energy += float(np.sum(lift * (data.xipos @ model.opt.gravity)))
    return energy


def body_speeds(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """(nbody - 1,) speed of every non-world body's center of mass, m/s (needs mj_comVel done).

    `cvel` holds the velocity of the point at the tree's subtree center of mass moving with the
    body, so the center-of-mass velocity is v_c + omega x (xipos - c).
    """
    cvel = data.cvel[1:]
    offset = data.xipos[1:] - data.subtree_com[model.body_rootid[1:]]
    return np.linalg.norm(cvel[:, 3:] + np.cross(cvel[:, :3], offset), axis=1)


class Watchdog:
    """Stateful checker for one trial.

    Energy bound: E(t) <= E(0) + W_act + M g H_up + 0.5 M v_hub^2 + slack, where W_act bounds the
    spring energy any change of rest shape can inject (four times the full-actuation bending energy
    0.5 EI kappa^2 L per filament, the energy of reversing a fully actuated curvature), M is the
    total moving mass and H_up the hub's cumulative rise.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        limits: WatchdogLimits,
        actuation_energy_j: float,
    ):
        self.limits = limits
        self.mass = float(np.sum(model.body_mass[model.body_mocapid < 0]))
        self.energy0 = mechanical_energy(model, data)
        self.actuation_energy = 4.0 * actuation_energy_j
        self.hub_rise = 0.0
        self.hub_speed = 0.0
        self.stats = WatchdogStats()
        self._hub = data.mocap_pos[0].copy() if model.nmocap else np.zeros(3)
        self._time = data.time
        self._start = data.time
        self._gravity = float(np.linalg.norm(model.opt.gravity)) if _gravity_on(model) else 0.0

    @property
    def energy_bound_j(self) -> float:
        """Largest mechanical energy the work put in so far allows, J."""
        return (
            self.energy0
            + self.actuation_energy
            + self.mass * self._gravity * self.hub_rise
            + 0.5 * self.mass * self.hub_speed**2
            + self.limits.energy_slack_j
        )

    def check(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Raise WatchdogTripped if the state is invalid; update `stats` otherwise."""
        t = data.time
        stats = self.stats
        stats.checks += 1
        for warning, name in WATCHED_WARNINGS.items():
            if data.warning[warning].number > 0:
                raise WatchdogTripped(f"mujoco_warning:{name}", t)
        if not (
            np.all(np.isfinite(data.qpos))
            and np.all(np.isfinite(data.qvel))
            and np.all(np.isfinite(data.qacc))
        ):
            raise WatchdogTripped("nan_or_inf_state", t)
        if model.nbody > 1:
            speed = float(np.max(body_speeds(model, data)))
            stats.max_speed_m_s = max(stats.max_speed_m_s, speed)
            if speed > self.limits.max_speed_m_s:
                raise WatchdogTripped(f"speed:{speed:.3g}m/s", t)
        if t - self._start >= self.limits.grace_time_s and data.ncon:
            depth = max(0.0, -float(np.min(data.contact.dist[: data.ncon])))
            stats.max_penetration_m = max(stats.max_penetration_m, depth)
            if depth > self.limits.max_penetration_m:
                raise WatchdogTripped(f"penetration:{depth * 1e3:.3g}mm", t)
        if model.nmocap and t > self._time:
            hub = data.mocap_pos[0]
            self.hub_rise += max(0.0, float(hub[2] - self._hub[2]))
            hub_speed = float(np.linalg.norm(hub - self._hub)) / (t - self._time)
            self.hub_speed = max(self.hub_speed, hub_speed)
            self._hub, self._time = hub.copy(), t
        bound = self.energy_bound_j
        energy = mechanical_energy(model, data)
        stats.max_energy_j = max(stats.max_energy_j, energy)
        stats.min_energy_margin_j = min(stats.min_energy_margin_j, bound - energy)
        if energy > bound:
            raise WatchdogTripped(f"energy:{energy:.3g}J>{bound:.3g}J", t)
