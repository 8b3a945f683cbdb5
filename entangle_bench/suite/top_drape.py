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
from entangle_bench.metrics.contacts import ObjectSupport
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
    max_tilt_deg: float = 45.0
    """Success also needs the object upright: its vertical axis within this angle of the world's for the whole
    hold, deg (a toppled or dangling object is not a grasp)."""
    max_pinched_support_w: float = 0.5
    """Success also needs the object carried by wraps and friction, not by a pinch: the mean upward force over
    the hold through filament segments that touch two object faces at once (`support.pinched_w`) at most this,
    in object weights (a segment squeezed between two faces of one rigid object is a clamp, and the force a
    soft-contact wedge builds comes from penetration, not from the filament)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("success_margin_m", self.success_margin_m, 0.0, 1.0, low_open=True)
        check_range("max_tilt_deg", self.max_tilt_deg, 0.0, 180.0, low_open=True)
        check_range("max_pinched_support_w", self.max_pinched_support_w, 0.0, 10.0)


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

    max_clearance_m: float = 0.0
    """Largest height of the object's lowest point above the ground so far, m (0 for one that only rolls)."""
    min_hold_clearance_m: float = math.inf
    """Smallest height of the object's lowest point above the ground during the hold, m (inf before the hold)."""
    lifted: bool = False
    """The object's lowest point cleared the success margin during the lift."""
    low_at_hold_start: bool = False
    hold_failed_at_s: float | None = None
    """Hold time at which the object first fell below the margin or tilted too far, s."""
    failed_by_tilt: bool = False
    """The hold failed because the object tilted beyond the limit while still above the margin."""
    hold_reached_s: float = 0.0
    """Hold time the object stayed above the margin and upright, s."""
    max_hold_tilt_deg: float = 0.0
    """Largest tilt of the object's vertical axis during the hold, deg."""
    peak_lift_force_n: float = 0.0
    """Largest upward force the filaments exerted on the object (lift and hold), N."""
    support_samples: int = 0
    support_z_n: dict[str, float] = field(default_factory=dict)
    """Sum over hold steps of the upward force on the object by source, N (`mean_support_n` averages it)."""

    def mean_support_n(self, source: str) -> float:
        """Mean upward force on the object from `source` over the hold so far, N (0 before the hold)."""
        return self.support_z_n.get(source, 0.0) / max(1, self.support_samples)


def object_tilt_deg(quat: np.ndarray) -> float:
    """Angle between an object's vertical axis (body z, quaternion w, x, y, z) and the world's, deg."""
    w, x, y, _ = quat
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


class TopDrape(DrapeTask[TopDrapeConfig]):
    """Drape the filament array over an object, actuate, lift and hold."""

    SNAPSHOTS = {"actuated": "lift", "held": "release"}
    SCHEDULE = Schedule
    schedule: Schedule
    _tracking: _GraspTracking

    def initialize_episode(self, physics: ScenePhysics) -> None:
        """Set up the drape (`DrapeTask`) and reset the grasp tracking."""
        super().initialize_episode(physics)
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
        """Track the grasp and what carries the object; decide the outcome once the hold is over.

        Success: for the whole hold the object's lowest point stays at least `success_margin_m` above the
        ground and its vertical axis within `max_tilt_deg` of the world's (not for an orientation-free object,
        a ball, whose tilt is recorded but not judged), and pinches carry at most `max_pinched_support_w` of its
        weight on average over the hold (not judged without gravity). Failure modes: never_lifted,
        dropped_during_lift (low when the hold starts), dropped_during_hold, tilted (held up but tipped),
        pinched (held up, but by a pinch).
        """
        t, s, track, cfg = physics.time(), self.schedule, self._tracking, self.config
        low, tilt = physics.object_lowest_z(), object_tilt_deg(physics.object_pose()[1])
        tilted = tilt > cfg.max_tilt_deg and not physics.object_orientation_free()
        track.max_clearance_m = max(track.max_clearance_m, low)
        phase = s.phase(t - 1e-9)
        if phase in ("lift", "hold"):
            support = physics.object_support()
            track.peak_lift_force_n = max(track.peak_lift_force_n, float(support.filament_total[2]))
        if phase == "lift" and low >= cfg.success_margin_m:
            track.lifted = True
        if phase == "hold":
            self._add_support(support)
            track.max_hold_tilt_deg = max(track.max_hold_tilt_deg, tilt)
            track.min_hold_clearance_m = min(track.min_hold_clearance_m, low)
            if track.hold_reached_s == 0.0 and low < cfg.success_margin_m:
                track.low_at_hold_start = True
            if track.hold_failed_at_s is None:
                if low < cfg.success_margin_m or tilted:
                    track.hold_failed_at_s = t - s.t_hold
                    track.failed_by_tilt = low >= cfg.success_margin_m
                else:
                    track.hold_reached_s = t - s.t_hold
        if t >= s.t_release - 1e-9 and self.outcome is None:
            self.decide(self._classify(t, float(np.linalg.norm(physics.object_weight()))))

    def _add_support(self, support: ObjectSupport) -> None:
        """Add one hold step's upward forces on the object by source to the running sums."""
        sums, track = self._tracking.support_z_n, self._tracking
        sources = {"ground": support.ground[2], "pinched": support.pinched[2],
                   "ground_pinched": support.ground_pinched[2]}
        for part, force in support.by_part.items():
            key = f"part.{part.rstrip('0123456789')}"
            sources[key] = sources.get(key, 0.0) + force[2]
        sources["filament_filament_normal"] = support.filament_filament_n
        for name, value in sources.items():
            sums[name] = sums.get(name, 0.0) + float(value)
        track.support_samples += 1

    def _classify(self, t: float, weight_n: float) -> Outcome:
        """The outcome from the tracking at the end of the hold (time t, s; the object's weight, N)."""
        track = self._tracking
        pinched_w = track.mean_support_n("pinched") / weight_n if weight_n > 0 else 0.0
        evidence = {
            "max_clearance_m": float(track.max_clearance_m),
            "lifted": float(track.lifted),
            "hold_reached_s": track.hold_reached_s,
            "hold_failed_at_s": math.nan if track.hold_failed_at_s is None else track.hold_failed_at_s,
            "max_hold_tilt_deg": track.max_hold_tilt_deg,
            "pinched_support_w": pinched_w,
        }
        if track.hold_failed_at_s is None:
            if pinched_w > self.config.max_pinched_support_w:
                return Outcome("failure", "pinched", t, evidence)
            return Outcome("success", "", t, evidence)
        if not track.lifted:
            mode = "never_lifted"
        elif track.low_at_hold_start:
            mode = "dropped_during_lift"
        elif track.failed_by_tilt:
            mode = "tilted"
        else:
            mode = "dropped_during_hold"
        return Outcome("failure", mode, t, evidence)

    def metrics(self, physics: ScenePhysics) -> dict[str, float]:
        """Clearance (m), hold reached (s), hold tilt (deg), peak lift force and the hold's support by source.

        `lift_clearance_m` is the largest height of the object's lowest point above the ground, the quantity the
        success margin judges (rows logged before it carry `lift_height_m`, the rise of the object's origin,
        which counts a roll of an object whose origin is on its surface as a lift); `hold_min_clearance_m` the
        smallest over the hold (NaN without a hold), which tells a drop from an object held up but below the margin.

        `peak_lift_force_w` and `support.<source>_w` are in units of the object's weight W; the support is the
        mean upward force over the hold by source (`part.<part>`: filaments on that part of the object,
        `pinched`, `ground_pinched`: filament segments between the object and the ground, `ground`);
        `support.filament_filament_normal_n` the mean normal force between filaments, N.
        """
        track = self._tracking
        weight = float(np.linalg.norm(physics.object_weight())) or math.nan
        row = {
            "lift_clearance_m": track.max_clearance_m,
            "hold_min_clearance_m": track.min_hold_clearance_m if track.support_samples else math.nan,
            "hold_time_reached_s": track.hold_reached_s,
            "max_hold_tilt_deg": track.max_hold_tilt_deg,
            "peak_lift_force_w": track.peak_lift_force_n / weight,
        }
        for name in sorted(track.support_z_n):
            mean = track.mean_support_n(name)
            if name == "filament_filament_normal":
                row["support.filament_filament_normal_n"] = mean
            else:
                row[f"support.{name}_w"] = mean / weight
        return row


register_object_tasks("top_drape", TopDrapeConfig, TopDrape, "top-drape lift-and-hold", tags=("benchmark",))
