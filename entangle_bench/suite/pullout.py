"""The pull-out task family: entanglement toughness and maximum grasp force, one task per object of the library.

Sequence (the pull-out test of Becker et al., PNAS 2022): approach, actuate and settle exactly as a top-drape
trial (`suite.drape`, same `phases.*` settings); clamp: the object is welded where it is to the world (the
testing machine's frame) and taken off the ground contact while the hub rests, so the weld takes over its
weight (an object held on a post, `pull.post_height_m`, is welded from the start); pull: the hub moves along
the pull direction, reaching `pull.speed_m_s` at constant acceleration within `pull.accel_time_s`, until the
object is free (pull force below `release_force_n` over `release_distance_m` of travel, once it carried that
force or while no filament touches it) or the hub has travelled `max_travel_m`.

The instrument reads the pull force two ways: from the weld's constraint rows, F = -(F_weld + m g) (the force the
gripper exerts on the object, its weight tared), and independently from the sum of the filament-object contact
forces; with the object held still they agree (`force_method_gap_n` is their largest difference). An object
ringing on its stiff weld moves the weld's reading by its m a, so the row also gives the contact sum's own peak
and toughness over the same span (`contact_peak_force_n`, `contact_toughness_j`). Every control
step of the pull, from its start, logs a `metrics.pullout.CurvePoint` (`states/<trial_id>_series.npz`, read with
`entangle_bench.pullout.read_curve`). Outcome: `released` or `slid_off` (failures: the grasp let go, slid_off if
it never carried the engagement force, `engage_weight_fraction` of the object's weight) or success (the grasp
still held at the largest travel: `pull_result` held, toughness a lower bound). Snapshots: `actuated` at the start
of the clamp and `peak`, the entanglement (ACN, contacts by kind) at the peak pull force.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.metrics.contacts import ContactSummary, contact_summary
from entangle_bench.metrics.pullout import CurvePoint, PullMetrics, ReleaseDetector, analyze_curve
from entangle_bench.scene import SceneConfig
from entangle_bench.suite.base import Outcome, Snapshot
from entangle_bench.suite.drape import DrapeConfig, DrapeSchedule, DrapeTask, register_object_tasks
from entangle_bench.suite.gripper_task import (
    MAX_HUB_SPEED_M_S,
    EnergyLedger,
    ScenePhysics,
    entanglement_snapshot,
)


@dataclass(frozen=True)
class PullParams:
    """The pull of a pull-out test: speed, direction, end criteria and the holding weld (SI units).

    The default speed, 10 mm/s, is of the order of a universal testing machine's crosshead speed in such tests
    and quasi-static for the filament: a millimetre of travel takes 100 ms, five times its damping time and 25
    times the contact time constant; a full 0.3 m pull is 30 s simulated.
    """

    speed_m_s: float = 0.01
    """Hub speed along the pull direction, m/s."""
    direction: tuple[float, float, float] = (0.0, 0.0, 1.0)
    """Direction the hub moves, world frame (normalized: any non-zero vector); vertical up by default."""
    accel_time_s: float = 0.1
    """Time to reach the pull speed from rest at constant acceleration, s (0: at once)."""
    max_travel_m: float = 0.30
    """Largest hub travel, m (the filament length); a grasp that still holds there is `held`."""
    clamp_time_s: float = 0.2
    """Hub at rest with the object welded before the pull, while the weld takes over its weight, s (at least
    ten timesteps: five time constants of the weld)."""
    release_force_n: float = 0.002
    """Release: the pull force stays below this over `release_distance_m` of travel, N."""
    release_distance_m: float = 0.01
    engage_weight_fraction: float = 0.1
    """Engagement force as a fraction of the object's weight (at least `release_force_n`): a release whose peak
    never reached it is `slid_off`."""
    anchor: Literal["world", "hub"] = "world"
    """What the weld holds the object to: the world (the test) or the hub (an instrument check: the weld then
    carries the object's weight and inertia, m (g + a))."""
    post_height_m: float = 0.0
    """Height of the post the object is held on, m (0: it stands on the ground and is welded at the clamp). On a
    post, as on a testing machine's fixture, it is welded from the start and the filaments hanging below it meet
    no ground there: no filament can be squeezed between it and the ground (`ground_pinch_toughness_j`)."""
    post_radius_m: float = 0.005
    """Radius of that post, m; 0: no post geom, the object is held at that height by the weld alone (nothing under
    it that a filament could loop around or be squeezed against)."""

    def __post_init__(self) -> None:
        check_range("pull.speed_m_s", self.speed_m_s, 0.0, MAX_HUB_SPEED_M_S, low_open=True)
        if len(self.direction) != 3:
            raise ParameterError(f"pull.direction = {self.direction!r} must have three components (x, y, z)")
        for axis, value in zip("xyz", self.direction):
            check_range(f"pull.direction.{axis}", value)
        norm = math.sqrt(sum(v * v for v in self.direction))
        if norm < 1e-9:
            raise ParameterError(f"pull.direction = {self.direction!r} has zero length; give a non-zero vector")
        object.__setattr__(self, "direction", tuple(float(v) / norm for v in self.direction))
        check_range("pull.accel_time_s", self.accel_time_s, 0.0, 10.0)
        check_range("pull.max_travel_m", self.max_travel_m, 0.0, 2.0, low_open=True)
        check_range("pull.clamp_time_s", self.clamp_time_s, 0.0, 10.0)
        check_range("pull.release_force_n", self.release_force_n, 0.0, 1000.0)
        check_range("pull.release_distance_m", self.release_distance_m, 0.0, 1.0, low_open=True)
        check_range("pull.engage_weight_fraction", self.engage_weight_fraction, 0.0, 100.0)
        check_choice("pull.anchor", self.anchor, ("world", "hub"))
        check_range("pull.post_height_m", self.post_height_m, 0.0, 1.0)
        check_range("pull.post_radius_m", self.post_radius_m, 0.0, 0.1)
        if self.post_height_m > 0 and self.anchor != "world":
            raise ParameterError(
                f"pull.post_height_m = {self.post_height_m} holds the object on a fixed post: it needs "
                f"pull.anchor = 'world', not {self.anchor!r}"
            )


@dataclass(frozen=True)
class PullOutConfig(DrapeConfig):
    """Everything that defines one pull-out trial except the seed: the drape over an object, then the pull."""

    pull: PullParams = field(default_factory=PullParams)

    def __post_init__(self) -> None:
        super().__post_init__()
        # Five time constants of the weld (2 dt): the weight must have moved onto it before the curve starts.
        check_range(
            "pull.clamp_time_s (relative to 10 * numerics.timestep_s)",
            self.pull.clamp_time_s,
            10.0 * self.numerics.timestep_s,
            None,
        )

    def scene_config(self) -> SceneConfig:
        """The scene: gripper, object, ground, the post if any and the (inactive) weld holding the object to
        `pull.anchor`."""
        return dataclasses.replace(
            super().scene_config(), object_weld=self.pull.anchor, post_height_m=self.pull.post_height_m,
            post_radius_m=self.pull.post_radius_m,
        )


@dataclass(frozen=True)
class PullSchedule(DrapeSchedule):
    """Phase boundaries of one pull-out trial (s): the drape, the clamp, and the latest end of the pull."""

    t_pull: float
    t_limit: float
    """Time by which the hub has surely travelled `max_travel_m` (the environment's time limit), s."""

    AFTER_SETTLE = ("clamp", "pull")

    @classmethod
    def after_settle(cls, config: PullOutConfig, t_settled: float) -> tuple[float, float]:
        """Start of the pull and its latest end, s."""
        pull = config.pull
        t_pull = t_settled + pull.clamp_time_s
        travel_time = pull.accel_time_s + pull.max_travel_m / pull.speed_m_s
        return t_pull, t_pull + travel_time + 3 * config.control_timestep_s


@dataclass
class _PullTracking:
    """Running record of the pull (SI units)."""

    detector: ReleaseDetector
    clamped: bool = False
    hub_start: np.ndarray | None = None
    """Hub position when the pull began, m."""
    displacement: list[float] = field(default_factory=list)
    force: list[float] = field(default_factory=list)
    contact_force: list[float] = field(default_factory=list)
    """Pull force from the filament-object contact sum, N (the second method)."""
    ground_pinch_force: list[float] = field(default_factory=list)
    """The part of the contact sum's pull force through filament segments that also touch the ground, N."""
    touching: list[bool] = field(default_factory=list)
    method_gap_n: float = 0.0
    """Largest |weld - contact| pull force so far, N."""
    point: CurvePoint | None = None
    """This control step's curve point (None outside the pull)."""
    peak_force_n: float = -math.inf
    peak_curves: np.ndarray | None = None
    peak_contacts: ContactSummary | None = None
    result: PullMetrics | None = None
    ledger: EnergyLedger | None = None


class PullOut(DrapeTask[PullOutConfig]):
    """Drape the filaments over an object, actuate, weld the object in place and pull the gripper away."""

    SCHEDULE = PullSchedule
    SNAPSHOTS = {"actuated": "clamp", "peak": "done"}
    _track: _PullTracking

    def initialize_episode(self, physics: ScenePhysics) -> None:
        """Release a weld left from a previous episode, set up the drape (`DrapeTask`), start a new record; an
        object on a post is welded at once."""
        physics.unclamp_object()
        super().initialize_episode(physics)
        pull = self.config.pull
        self._track = _PullTracking(ReleaseDetector(pull.release_force_n, pull.release_distance_m))
        if pull.post_height_m > 0:
            physics.clamp_object()
            self._track.clamped = True

    def phase(self, physics: ScenePhysics) -> str:
        """Phase the next control step runs in; 'done' once the outcome is decided."""
        return "done" if self.outcome is not None else self.schedule.phase(physics.time() + 1e-9)

    def scripted_action(self, physics: ScenePhysics) -> np.ndarray:
        """The reference policy: the drape, then the hub at rest (clamp) and moving along the pull direction."""
        t, pull = physics.time(), self.config.pull
        drape = self.drape_action(t)
        if drape is not None:
            return np.array([0.0, 0.0, drape[0], min(1.0, max(0.0, drape[1]))])
        speed = 0.0
        if self.phase(physics) == "pull":
            # Velocity at the middle of the coming control step: the hub's travel follows the ramp exactly.
            elapsed = t + 0.5 * self.config.control_timestep_s - self.schedule.t_pull
            ramp = min(1.0, elapsed / pull.accel_time_s) if pull.accel_time_s > 0 else 1.0
            speed = pull.speed_m_s * max(0.0, ramp)
        return np.array([*(speed * np.asarray(pull.direction)), 1.0])

    def before_step(self, action: np.ndarray, physics: ScenePhysics) -> None:
        """Weld the object in place when the clamp begins; then set hub velocity and pressure."""
        if not self._track.clamped and physics.time() >= self.schedule.t_settled - 1e-9:
            physics.clamp_object()
            self._track.clamped = True
        self._track.point = None
        super().before_step(action, physics)

    def after_step(self, physics: ScenePhysics) -> None:
        """From the start of the pull: log the curve point, track the peak, decide once released or travelled."""
        track, pull, t = self._track, self.config.pull, physics.time()
        if not track.clamped or t < self.schedule.t_pull - 1e-9 or self.outcome is not None:
            return
        # Forces and contacts are those of the last physics step's forward pass: the ones that moved the bodies.
        # (A new forward pass would not do: the weld cannot see the mocap hub's velocity, so only the step's own
        # pass, with the hub already advanced, holds the force that moved an object welded to it.)
        if track.hub_start is None:
            track.hub_start = physics.hub_position()
            track.ledger = physics.start_ledger()
        direction = np.asarray(pull.direction)
        weld = physics.object_weld_force()
        force = -(weld + physics.object_weight())
        if force @ direction > track.peak_force_n:
            track.peak_force_n = float(force @ direction)
            track.peak_curves = physics.centerlines()
            track.peak_contacts = contact_summary(physics.model.ptr, physics.data.ptr, physics.scene.geoms)
        support = physics.object_support()
        contact = support.filament_total
        ledger = track.ledger
        point = CurvePoint(
            displacement_m=float((physics.hub_position() - track.hub_start) @ direction),
            pull_force_n=float(force @ direction),
            contact_pull_force_n=float(contact @ direction),
            ground_pinch_pull_force_n=float(support.ground_pinched @ direction),
            force_n=force,
            contact_force_n=contact,
            weld_force_n=weld,
            contacts=physics.contact_counts(active_only=True),
            hub_work_j=ledger.hub_work_j,
            damping_loss_j=ledger.damping_loss_j,
            constraint_work_j=ledger.constraint_work_j,
            mechanical_energy_j=physics.mechanical_energy_j(),  # last: it recomputes the kinematics
        )
        track.point = point
        track.displacement.append(point.displacement_m)
        track.force.append(point.pull_force_n)
        track.contact_force.append(point.contact_pull_force_n)
        track.ground_pinch_force.append(point.ground_pinch_pull_force_n)
        track.touching.append(point.contacts["filament-object"] > 0)
        track.method_gap_n = max(track.method_gap_n, abs(point.pull_force_n - point.contact_pull_force_n))
        released = track.detector.update(point.displacement_m, point.pull_force_n, track.touching[-1])
        if released or point.displacement_m >= pull.max_travel_m - 1e-9:
            track.result = analyze_curve(
                track.displacement,
                track.force,
                track.touching,
                release_force_n=pull.release_force_n,
                release_distance_m=pull.release_distance_m,
                engage_force_n=self.engage_force_n(physics),
                max_travel_m=pull.max_travel_m,
                second_force_n=track.contact_force,
            )
            result = track.result
            evidence = {
                "peak_force_n": result.peak_force_n,
                "toughness_j": result.toughness_j,
                "displacement_at_release_m": result.displacement_at_release_m,
                "travel_m": result.travel_m,
            }
            if result.result == "held":
                self.decide(Outcome("success", "", t, evidence))
            else:
                self.decide(Outcome("failure", result.result, t, evidence))

    def engage_force_n(self, physics: ScenePhysics) -> float:
        """Force the grasp must carry to count as engaged: a fraction of the weight, at least the release force, N."""
        pull = self.config.pull
        weight = float(np.linalg.norm(physics.object_weight()))
        return max(pull.engage_weight_fraction * weight, pull.release_force_n)

    def series_point(self, physics: ScenePhysics) -> dict[str, float]:
        """This control step's curve point (`CurvePoint.as_series`), from the start of the pull; else none."""
        return {} if self._track.point is None else self._track.point.as_series()

    def get_termination(self, physics: ScenePhysics) -> float | None:
        """End the episode (discount 1) once the outcome is decided."""
        return 1.0 if self.outcome is not None else None

    def snapshot(self, physics: ScenePhysics) -> Snapshot:
        """`actuated`: the current state; `peak` (taken once done): the state at the peak pull force."""
        track = self._track
        if self.phase(physics) == "done" and track.peak_curves is not None and track.peak_contacts is not None:
            return entanglement_snapshot(track.peak_curves, track.peak_contacts)
        return super().snapshot(physics)

    def metrics(self, physics: ScenePhysics) -> dict[str, float | str | bool]:
        """Pull result, peak force (N), toughness (J), both also from the contact sum, displacements (m), hub work
        (J), method gap (N); NaN if none.

        `ground_pinch_peak_force_n` (over the pull) and `ground_pinch_toughness_j` (over the toughness's span) are
        the contact sum's peak and integral through filament segments squeezed between the object and the ground:
        with the object welded on the ground, such a segment can be dragged out of a pinch that a free object would
        not hold shut, so that share is a property of the test, not of the entanglement.
        """
        track, result = self._track, self._track.result
        row: dict[str, float | str | bool] = {
            "pull_result": "",
            "peak_force_n": math.nan,
            "toughness_j": math.nan,
            "contact_peak_force_n": math.nan,
            "contact_toughness_j": math.nan,
            "ground_pinch_peak_force_n": math.nan,
            "ground_pinch_toughness_j": math.nan,
            "toughness_is_lower_bound": False,
            "displacement_at_peak_m": math.nan,
            "displacement_at_release_m": math.nan,
            "travel_m": math.nan,
            "hub_work_j": math.nan if track.ledger is None else track.ledger.hub_work_j,
            "force_method_gap_n": track.method_gap_n if track.displacement else math.nan,
            "engage_force_n": self.engage_force_n(physics),
            "object_weight_n": float(np.linalg.norm(physics.object_weight())),
        }
        if result is not None:
            row |= {
                "pull_result": result.result,
                "peak_force_n": result.peak_force_n,
                "toughness_j": result.toughness_j,
                "contact_peak_force_n": result.second_peak_force_n,
                "contact_toughness_j": result.second_toughness_j,
                **_ground_pinch(track, result),
                "toughness_is_lower_bound": result.toughness_is_lower_bound,
                "displacement_at_peak_m": result.displacement_at_peak_m,
                "displacement_at_release_m": result.displacement_at_release_m,
                "travel_m": result.travel_m,
            }
        return row


def _ground_pinch(track: _PullTracking, result: PullMetrics) -> dict[str, float]:
    """Peak (N) and integral (J) of the ground-pinched pull force over the toughness's span (to the release)."""
    x, f, end = np.asarray(track.displacement), np.asarray(track.ground_pinch_force), result.span_points
    toughness = float(np.trapezoid(f[:end], x[:end])) if result.result else math.nan
    return {"ground_pinch_peak_force_n": float(f.max()), "ground_pinch_toughness_j": toughness}


register_object_tasks("pullout", PullOutConfig, PullOut, "pull-out test", tags=("pullout",))
