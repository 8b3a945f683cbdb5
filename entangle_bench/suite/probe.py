"""The stability probe as a task: a gripper alone in air, a pressure ramp, then a hold, under the watchdog.

The hub hangs fixed at `hub_height_m`; every filament joint starts perturbed by `perturbation_rad`; the
pressure ramps linearly to the operating pressure in `ramp_time_s` and is held until `duration_s`. The
trial succeeds when it reaches `duration_s`; whether it stayed stable is the runner's watchdog's call, as for
every task. `entangle_bench.studies.stability_map` sweeps it over modulus x timestep x segments; the default
configuration is the map's array (`stability.MAP_GRIPPER`: three filaments curling into each other).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from dm_control.rl import control

from entangle_bench.config import check_range
from entangle_bench.gripper import GripperParams
from entangle_bench.scene import build_scene
from entangle_bench.stability import MAP_GRIPPER
from entangle_bench.suite.base import Outcome, register_task
from entangle_bench.suite.gripper_task import GripperTask, GripperTaskConfig, ScenePhysics
from entangle_bench.watchdog import WatchdogLimits

PHASES = ("ramp", "hold", "done")


@dataclass(frozen=True)
class ProbeConfig(GripperTaskConfig):
    """A gripper hanging in air (no object) and its pressure ramp (SI units)."""

    gripper: GripperParams = field(default_factory=lambda: MAP_GRIPPER)
    perturbation_rad: float = 0.05
    hub_height_m: float = 0.5
    """Height of the fixed hub, m."""
    ramp_time_s: float = 0.3
    """Pressure ramp from 0 to the operating pressure, s (0: full pressure at once)."""
    duration_s: float = 1.0
    """Simulated time of the probe, s."""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("hub_height_m", self.hub_height_m, 0.0, 10.0, low_open=True)
        check_range("ramp_time_s", self.ramp_time_s, 0.0, 60.0)
        check_range("duration_s", self.duration_s, 0.0, 600.0, low_open=True)


class Probe(GripperTask[ProbeConfig]):
    """Ramp the pressure of a gripper hanging in air, then hold it."""

    PHASES = PHASES

    def initialize_episode(self, physics: ScenePhysics) -> None:
        """Draw bending planes and joint perturbations from the seed."""
        self.reset_actuation(physics)
        self.perturb_joints(physics, self.config.perturbation_rad)
        super().initialize_episode(physics)

    def phase(self, physics: ScenePhysics) -> str:
        """'ramp' until the ramp time, 'hold' until the duration, then 'done'."""
        t = physics.time() + 1e-9
        if t < self.config.ramp_time_s - 1e-9:
            return "ramp"
        return "hold" if t < self.config.duration_s - 1e-9 else "done"

    def scripted_action(self, physics: ScenePhysics) -> np.ndarray:
        """Hub at rest, pressure fraction t / ramp_time_s (at most 1)."""
        ramp = self.config.ramp_time_s
        fraction = min(1.0, physics.time() / ramp) if ramp > 0 else 1.0
        return np.array([0.0, 0.0, 0.0, fraction])

    def after_step(self, physics: ScenePhysics) -> None:
        """Decide success once the probe reaches its duration."""
        t = physics.time()
        if t >= self.config.duration_s - 1e-9 and self.outcome is None:
            self.decide(Outcome("success", decided_at_s=t, evidence={"duration_s": t}))

    def get_termination(self, physics: ScenePhysics) -> float | None:
        """End the episode (discount 1) once the duration is reached."""
        return 1.0 if physics.time() >= self.config.duration_s - 1e-9 else None

    def metrics(self, physics: ScenePhysics) -> dict[str, float]:
        """Mean root-to-tip distance over the filament length at the end (1 straight, < 1 curled)."""
        curves = physics.centerlines()
        span = np.linalg.norm(curves[:, -1] - curves[:, 0], axis=1)
        return {"span_ratio": float(np.mean(span) / self.config.gripper.filament.length_m)}

    def watchdog_limits(self) -> WatchdogLimits:
        """10 m/s; energy slack 10 % of the actuation plus lifting energy of the filaments, J.

        The trial default slack, 0.05 J, would hide the blow-up of a few light filaments.
        """
        gripper = self.config.gripper
        fil = gripper.filament
        lift = gripper.n_filaments * fil.mass_kg * 9.81 * fil.length_m
        return WatchdogLimits(max_speed_m_s=10.0, energy_slack_j=0.1 * (gripper.actuation_energy_j + lift))


def make_environment(config: ProbeConfig, seed: int) -> control.Environment:
    """Build the dm-control environment of one probe."""
    scene = build_scene(config.scene_config(), hub_pos=(0.0, 0.0, config.hub_height_m))
    return control.Environment(
        ScenePhysics.from_scene(scene),
        Probe(config, seed),
        time_limit=math.inf,
        n_sub_steps=config.n_sub_steps,
    )


@register_task("probe/curl_in_air", config_type=ProbeConfig, make_environment=make_environment, tags=("stability",))
def curl_in_air() -> ProbeConfig:
    """Stability probe: three filaments 8.7 mm apart curling into each other in air, under the watchdog."""
    return ProbeConfig()
