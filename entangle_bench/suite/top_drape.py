"""The top-drape lift-and-hold task family: one registered task per object of the object library.

Sequence (Becker et al., PNAS 2022): approach (the hub lowers so the hanging filaments drape over the object)
-> actuate (pressure ramp) -> settle -> lift -> hold -> release. The task initializes episodes, computes
observations, reward and the grasp outcome (decided once, at the end of the hold); it never steps the physics.
The action is hub velocity (m/s) plus the pressure as a fraction of the operating pressure, so a learned policy
can drive the same environment; the benchmark drives it with `TopDrape.scripted_action`. Snapshots `actuated`
and `held` are taken at the start of the lift and of the release.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from entangle_bench.config import check_range
from entangle_bench.suite.base import Outcome
from entangle_bench.suite.drape import (
    DrapeConfig,
    DrapePhases,
    DrapeSchedule,
    DrapeTask,
    register_object_tasks,
)
from entangle_bench.suite.gripper_task import MAX_HUB_SPEED_M_S, ScenePhysics


@dataclass(frozen=True)
class Phases(DrapePhases):
    """Timing and geometry of the scripted top-drape sequence (SI units): the drape, then the lift (hub speed
    `lift_speed_m_s`), the hold (`hold_time_s`) and the release (pressure back to zero in `release_time_s`)."""

    lift_height_m: float = 0.10
    """Hub rise during the lift, m."""
    lift_speed_m_s: float = 0.05
    hold_time_s: float = 2.0
    release_time_s: float = 0.5

    def __post_init__(self) -> None:
        for name, high in (("lift_height_m", 2.0), ("lift_speed_m_s", MAX_HUB_SPEED_M_S), ("hold_time_s", 600.0)):
            check_range(f"phases.{name}", getattr(self, name), 0.0, high, low_open=True)
        check_range("phases.release_time_s", self.release_time_s, 0.0, 60.0)
        super().__post_init__()


@dataclass(frozen=True)
class TopDrapeConfig(DrapeConfig):
    """Everything that defines one top-drape trial except the seed: the gripper scene plus object and sequence."""

    phases: Phases = field(default_factory=Phases)
    success_margin_m: float = 0.02
    """Success: the object's lowest point stays at least this far above the ground for the whole hold, m."""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("success_margin_m", self.success_margin_m, 0.0, 1.0, low_open=True)


@dataclass(frozen=True)
class Schedule(DrapeSchedule):
    """Absolute phase boundaries (s) and hub heights (m) of one top-drape trial."""

    t_hold: float
    t_release: float
    t_end: float

    AFTER_SETTLE = ("lift", "hold", "release")

    @classmethod
    def after_settle(cls, config: TopDrapeConfig, t_settled: float) -> tuple[float, float, float]:
        """Ends of the lift, hold and release, s."""
        ph = config.phases
        t_hold = t_settled + ph.lift_height_m / ph.lift_speed_m_s
        t_release = t_hold + ph.hold_time_s
        return t_hold, t_release, t_release + ph.release_time_s

    @property
    def t_lift(self) -> float:
        """Start of the lift (the end of the settle), s."""
        return self.t_settled


@dataclass
class _GraspTracking:
    """Running bookkeeping of the grasp, updated after every control step (SI units)."""

    max_rise_m: float = 0.0
    """Largest rise of the object's origin above its start so far, m."""
    lifted: bool = False
    """The object's lowest point cleared the success margin during the lift."""
    low_at_hold_start: bool = False
    hold_failed_at_s: float | None = None
    """Hold time at which the object first fell below the margin, s."""
    hold_reached_s: float = 0.0
    """Hold time the object stayed above the margin, s."""


class TopDrape(DrapeTask[TopDrapeConfig]):
    """Drape the filament array over an object, actuate, lift and hold."""

    SNAPSHOTS = {"actuated": "lift", "held": "release"}
    SCHEDULE = Schedule
    schedule: Schedule
    _tracking: _GraspTracking
    _object_z0: float
    """Height of the object's origin at the start, m."""

    def initialize_episode(self, physics: ScenePhysics) -> None:
        """Set up the drape (`DrapeTask`); remember the object's height and reset the grasp tracking."""
        super().initialize_episode(physics)
        self._object_z0 = physics.object_pose()[0][2]
        self._tracking = _GraspTracking()

    def phase(self, physics: ScenePhysics) -> str:
        """Phase of the scripted sequence the next control step runs in."""
        return self.schedule.phase(physics.time() + 1e-9)

    def scripted_action(self, physics: ScenePhysics) -> np.ndarray:
        """The reference open-loop policy: (hub vx, vy, vz in m/s, pressure fraction) at the current time."""
        ph, schedule, t = self.config.phases, self.schedule, physics.time()
        phase = schedule.phase(t)
        vz, pressure = self.drape_action(t) or (0.0, 0.0)
        if phase == "hold":
            pressure = 1.0
        elif phase == "lift":
            vz, pressure = ph.lift_speed_m_s, 1.0
        elif phase == "release":
            pressure = 1.0 - (t - schedule.t_release) / ph.release_time_s if ph.release_time_s > 0 else 0.0
        return np.array([0.0, 0.0, vz, min(1.0, max(0.0, pressure))])

    def after_step(self, physics: ScenePhysics) -> None:
        """Track the grasp; decide the outcome once the hold is over.

        Success: the object's lowest point stays at least `success_margin_m` above the ground for the whole
        hold. Failure modes: never_lifted, dropped_during_lift (low when the hold starts),
        dropped_during_hold.
        """
        t, s, track = physics.time(), self.schedule, self._tracking
        low = physics.object_lowest_z()
        margin = self.config.success_margin_m
        track.max_rise_m = max(track.max_rise_m, physics.object_pose()[0][2] - self._object_z0)
        phase = s.phase(t - 1e-9)
        if phase == "lift" and low >= margin:
            track.lifted = True
        if phase == "hold":
            if track.hold_reached_s == 0.0 and low < margin:
                track.low_at_hold_start = True
            if track.hold_failed_at_s is None:
                if low < margin:
                    track.hold_failed_at_s = t - s.t_hold
                else:
                    track.hold_reached_s = t - s.t_hold
        if t >= s.t_release - 1e-9 and self.outcome is None:
            self.decide(self._classify(t))

    def _classify(self, t: float) -> Outcome:
        """The outcome from the tracking at the end of the hold (time t, s)."""
        track = self._tracking
        evidence = {
            "max_rise_m": float(track.max_rise_m),
            "lifted": float(track.lifted),
            "hold_reached_s": track.hold_reached_s,
            "hold_failed_at_s": math.nan if track.hold_failed_at_s is None else track.hold_failed_at_s,
        }
        if track.hold_failed_at_s is None:
            return Outcome("success", "", t, evidence)
        if not track.lifted:
            mode = "never_lifted"
        elif track.low_at_hold_start:
            mode = "dropped_during_lift"
        else:
            mode = "dropped_during_hold"
        return Outcome("failure", mode, t, evidence)

    def metrics(self, physics: ScenePhysics) -> dict[str, float]:
        """Largest rise of the object over the trial (m) and how long the hold held (s)."""
        return {"lift_height_m": self._tracking.max_rise_m, "hold_time_reached_s": self._tracking.hold_reached_s}


register_object_tasks("top_drape", TopDrapeConfig, TopDrape, "top-drape lift-and-hold", tags=("benchmark",))
