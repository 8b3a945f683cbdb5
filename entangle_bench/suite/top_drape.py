"""The top-drape lift-and-hold task as a dm-control environment.

Sequence (Becker et al., PNAS 2022): approach (the hub lowers so the hanging filaments drape over the object)
-> actuate (pressure ramp) -> settle -> lift -> hold -> release. The task initializes episodes, computes
observations, reward and the grasp outcome; it never steps the physics. The action is hub velocity (m/s) plus
the pressure as a fraction of the operating pressure, so a learned policy can drive the same environment;
the benchmark drives it with `scripted_action`.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_control.rl import control
from dm_control.suite import base
from dm_env import specs

from entangle_bench import effects as fx
from entangle_bench.config import check_range
from entangle_bench.gripper import GripperParams, bending_angles
from entangle_bench.metrics.contacts import KINDS, classify_geom_pairs
from entangle_bench.presets import Numerics
from entangle_bench.scene import ContactParams, Scene, SceneConfig, build_scene

MAX_HUB_SPEED_M_S = 2.0
PHASES = ("approach", "actuate", "settle", "lift", "hold", "release", "done")


@dataclass(frozen=True)
class Phases:
    """Timing and geometry of the scripted top-drape sequence (SI units)."""

    start_clearance_m: float = 0.01
    """Gap between the straight filament tips and the object's top at the start, m."""
    drape_depth_m: float = 0.10
    """How far below the object's top the straight filament tips would reach at the end of the approach, m."""
    approach_speed_m_s: float = 0.1
    ramp_time_s: float = 1.0
    """Pressure ramp from 0 to the operating pressure, s."""
    settle_time_s: float = 1.0
    lift_height_m: float = 0.10
    """Hub rise during the lift, m."""
    lift_speed_m_s: float = 0.05
    hold_time_s: float = 2.0
    release_time_s: float = 0.5

    def __post_init__(self) -> None:
        check_range("phases.start_clearance_m", self.start_clearance_m, 0.0, 1.0)
        check_range("phases.drape_depth_m", self.drape_depth_m, 0.0, 1.0)
        check_range("phases.approach_speed_m_s", self.approach_speed_m_s, 0.0, MAX_HUB_SPEED_M_S, low_open=True)
        check_range("phases.ramp_time_s", self.ramp_time_s, 0.0, 60.0)
        check_range("phases.settle_time_s", self.settle_time_s, 0.0, 60.0)
        check_range("phases.lift_height_m", self.lift_height_m, 0.0, 2.0, low_open=True)
        check_range("phases.lift_speed_m_s", self.lift_speed_m_s, 0.0, MAX_HUB_SPEED_M_S, low_open=True)
        check_range("phases.hold_time_s", self.hold_time_s, 0.0, 600.0, low_open=True)
        check_range("phases.release_time_s", self.release_time_s, 0.0, 60.0)


@dataclass(frozen=True)
class TopDrapeConfig:
    """Everything that defines one top-drape trial except the seed."""

    object_name: str = "eight_branch_tree"
    object: Any = None
    """The object's parameter dataclass (None: the object's defaults)."""
    gripper: GripperParams = field(default_factory=GripperParams)
    effects: fx.Effects = field(default_factory=fx.Effects)
    contact: ContactParams = field(default_factory=ContactParams)
    numerics: Numerics = field(default_factory=Numerics)
    phases: Phases = field(default_factory=Phases)
    offset_m: float = 0.0
    """Centering offset: horizontal distance between the gripper axis and the object axis, m."""
    offset_angle_rad: float | None = None
    """Direction of the offset; None draws it uniformly from the trial seed."""
    perturbation_rad: float = 0.01
    """Standard deviation of the random initial joint rotations of the filaments, rad."""
    success_margin_m: float = 0.02
    """Success: the object's lowest point stays at least this far above the ground for the whole hold, m."""
    control_timestep_s: float = 0.01
    """Target control period, s; rounded to a whole number of physics steps."""

    def __post_init__(self) -> None:
        check_range("offset_m", self.offset_m, 0.0, 1.0)
        if self.offset_angle_rad is not None:
            check_range("offset_angle_rad", self.offset_angle_rad, -2 * math.pi, 2 * math.pi)
        check_range("perturbation_rad", self.perturbation_rad, 0.0, 0.5)
        check_range("success_margin_m", self.success_margin_m, 0.0, 1.0, low_open=True)
        check_range("control_timestep_s", self.control_timestep_s, 1e-4, 0.1)

    @property
    def n_sub_steps(self) -> int:
        """Physics steps per control step: the control timestep rounded to whole physics steps."""
        return max(1, round(self.control_timestep_s / self.numerics.timestep_s))

    def scene_config(self) -> SceneConfig:
        """The scene part of the configuration."""
        return SceneConfig(
            gripper=self.gripper,
            object_name=self.object_name,
            object_params=self.object,
            effects=self.effects,
            contact=self.contact,
            numerics=self.numerics,
        )


@dataclass(frozen=True)
class Schedule:
    """Absolute phase boundaries (s) and hub heights (m) of one trial."""

    hub_start_z: float
    hub_drape_z: float
    t_actuate: float
    t_settle: float
    t_lift: float
    t_hold: float
    t_release: float
    t_end: float

    @classmethod
    def from_config(cls, config: TopDrapeConfig, object_height_m: float) -> Schedule:
        """Phase times for an object of the given height."""
        ph, length = config.phases, config.gripper.filament.length_m
        start = object_height_m + length + ph.start_clearance_m
        drape = object_height_m + length - ph.drape_depth_m
        t_actuate = (start - drape) / ph.approach_speed_m_s
        t_settle = t_actuate + ph.ramp_time_s
        t_lift = t_settle + ph.settle_time_s
        t_hold = t_lift + ph.lift_height_m / ph.lift_speed_m_s
        t_release = t_hold + ph.hold_time_s
        return cls(start, drape, t_actuate, t_settle, t_lift, t_hold, t_release, t_release + ph.release_time_s)

    def phase(self, t: float) -> str:
        """Name of the phase at time t (s)."""
        bounds = (self.t_actuate, self.t_settle, self.t_lift, self.t_hold, self.t_release, self.t_end)
        for name, end in zip(PHASES, bounds):
            if t < end - 1e-9:
                return name
        return "done"


def scripted_action(config: TopDrapeConfig, schedule: Schedule, t: float) -> np.ndarray:
    """The reference open-loop policy: (hub vx, vy, vz in m/s, pressure fraction) at time t (s)."""
    ph = config.phases
    phase = schedule.phase(t)
    vz, pressure = 0.0, 0.0
    if phase == "approach":
        vz = -ph.approach_speed_m_s
    elif phase == "actuate":
        pressure = (t - schedule.t_actuate) / ph.ramp_time_s if ph.ramp_time_s > 0 else 1.0
    elif phase in ("settle", "hold"):
        pressure = 1.0
    elif phase == "lift":
        vz, pressure = ph.lift_speed_m_s, 1.0
    elif phase == "release":
        pressure = 1.0 - (t - schedule.t_release) / ph.release_time_s if ph.release_time_s > 0 else 0.0
    return np.array([0.0, 0.0, vz, min(1.0, max(0.0, pressure))])


class Physics(dm_mujoco.Physics):
    """MuJoCo physics of a top-drape scene with named read-outs; the hub moves at `hub_velocity` each substep."""

    scene: Scene
    hub_velocity: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> Physics:
        """Wrap a compiled scene."""
        physics = cls.from_model(dm_mujoco.wrapper.MjModel(scene.model))
        physics.scene = scene
        physics.hub_velocity = np.zeros(3)
        return physics

    def step(self, nstep: int = 1) -> None:
        """Advance `nstep` physics steps, moving the mocap hub by hub_velocity * dt before each."""
        model, data = self.model.ptr, self.data.ptr
        with self.check_invalid_state():
            for _ in range(nstep):
                data.mocap_pos[0] += self.hub_velocity * model.opt.timestep
                mujoco.mj_step(model, data)

    def hub_position(self) -> np.ndarray:
        """Hub position, m."""
        return self.data.mocap_pos[0].copy()

    def object_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Object position (m) and quaternion."""
        body = self.scene.object_body
        return self.data.xpos[body].copy(), self.data.xquat[body].copy()

    def object_lowest_z(self) -> float:
        """Lower bound of the object's lowest point from its geoms' bounding boxes, m."""
        model, data = self.model.ptr, self.data.ptr
        ids = np.flatnonzero(self.scene.is_object_geom)
        rot = data.geom_xmat[ids].reshape(-1, 3, 3)
        center = data.geom_xpos[ids] + np.einsum("gij,gj->gi", rot, model.geom_aabb[ids, :3])
        reach = np.einsum("gj,gj->g", np.abs(rot[:, 2, :]), model.geom_aabb[ids, 3:])
        return float(np.min(center[:, 2] - reach))

    def centerlines(self) -> np.ndarray:
        """(F, n + 1, 3) filament centerlines, m."""
        return self.scene.gripper.centerlines(self.model.ptr, self.data.ptr)

    def contact_counts(self) -> dict[str, int]:
        """Active contacts by kind."""
        return count_contacts(self.scene, self.data.ptr)


def count_contacts(scene: Scene, data: mujoco.MjData) -> dict[str, int]:
    """Numbers of active contacts by kind (`metrics.contacts.KINDS`)."""
    kinds = classify_geom_pairs(
        data.contact.geom[: data.ncon], scene.filament_of_geom, scene.is_object_geom, scene.is_ground_geom
    )
    return {kind: int(np.count_nonzero(kinds == kind)) for kind in KINDS}


@dataclass
class Outcome:
    """Grasp bookkeeping updated after every control step."""

    max_rise_m: float = 0.0
    lifted: bool = False
    low_at_hold_start: bool = False
    hold_failed_at_s: float | None = None
    hold_reached_s: float = 0.0
    finished: bool = False

    def classify(self) -> tuple[bool, str]:
        """(success, failure mode) once the hold is over; failure mode '' on success."""
        if self.hold_failed_at_s is None and self.finished:
            return True, ""
        if not self.lifted:
            return False, "never_lifted"
        if self.low_at_hold_start:
            return False, "dropped_during_lift"
        return False, "dropped_during_hold"


class TopDrape(base.Task):
    """Drape the filament array over an object, actuate, lift and hold."""

    def __init__(self, config: TopDrapeConfig, object_height_m: float, seed: int):
        super().__init__(random=seed)
        self.config = config
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self.schedule = Schedule.from_config(config, object_height_m)
        self.angles = np.zeros(config.gripper.n_filaments)
        self.outcome = Outcome()
        self._object_z0 = 0.0
        self._pressure_fraction = 0.0

    def initialize_episode(self, physics: Physics) -> None:
        """Draw bending planes, offset direction and joint perturbations; place the hub above the object."""
        cfg, model, data = self.config, physics.model.ptr, physics.data.ptr
        self.angles = bending_angles(cfg.gripper, self.rng)
        angle = self.rng.uniform(-math.pi, math.pi) if cfg.offset_angle_rad is None else cfg.offset_angle_rad
        data.mocap_pos[0] = (
            cfg.offset_m * math.cos(angle),
            cfg.offset_m * math.sin(angle),
            self.schedule.hub_start_z,
        )
        physics.scene.gripper.set_pressure(model, 0.0, self.angles)
        adr = physics.scene.gripper.spring_addresses.reshape(-1, 4)
        rotvec = self.rng.normal(0.0, cfg.perturbation_rad, size=(len(adr), 3))
        quat = np.empty(4)
        for row, vec in zip(adr, rotvec):
            angle = float(np.linalg.norm(vec))
            mujoco.mju_axisAngle2Quat(quat, vec / (angle + 1e-300), angle)
            data.qpos[row] = quat
        physics.hub_velocity[:] = 0.0
        mujoco.mj_kinematics(model, data)
        self._object_z0 = physics.object_pose()[0][2]
        self.outcome = Outcome()
        self._pressure_fraction = 0.0

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        """Hub velocity (m/s, 3) and pressure fraction (0..1)."""
        v = MAX_HUB_SPEED_M_S
        return specs.BoundedArray(
            (4,), np.float64, minimum=(-v, -v, -v, 0.0), maximum=(v, v, v, 1.0), name="hub_velocity_pressure"
        )

    def before_step(self, action: np.ndarray, physics: Physics) -> None:
        """Set the hub velocity and the shared pressure."""
        action = np.asarray(action, dtype=float)
        physics.hub_velocity[:] = np.clip(action[:3], -MAX_HUB_SPEED_M_S, MAX_HUB_SPEED_M_S)
        fraction = float(np.clip(action[3], 0.0, 1.0))
        if fraction != self._pressure_fraction:
            self._pressure_fraction = fraction
            physics.scene.gripper.set_pressure(
                physics.model.ptr, fraction * self.config.gripper.pressure_pa, self.angles
            )

    def after_step(self, physics: Physics) -> None:
        """Track the grasp outcome."""
        t, s, out = physics.time(), self.schedule, self.outcome
        low = physics.object_lowest_z()
        margin = self.config.success_margin_m
        out.max_rise_m = max(out.max_rise_m, physics.object_pose()[0][2] - self._object_z0)
        phase = s.phase(t - 1e-9)
        if phase == "lift" and low >= margin:
            out.lifted = True
        if phase == "hold":
            if out.hold_reached_s == 0.0 and low < margin:
                out.low_at_hold_start = True
            if out.hold_failed_at_s is None:
                if low < margin:
                    out.hold_failed_at_s = t - s.t_hold
                else:
                    out.hold_reached_s = t - s.t_hold
        if t >= s.t_release - 1e-9:
            out.finished = True

    @property
    def pressure_pa(self) -> float:
        """Current commanded pressure, Pa."""
        return self._pressure_fraction * self.config.gripper.pressure_pa

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        """Filament centerlines, hub and object pose, contact counts, pressure."""
        pos, quat = physics.object_pose()
        counts = physics.contact_counts()
        return collections.OrderedDict(
            centerlines=physics.centerlines().ravel(),
            hub_position=physics.hub_position(),
            object_position=pos,
            object_quaternion=quat,
            contact_counts=np.array(list(counts.values()), dtype=float),
            pressure=np.array([self.pressure_pa]),
        )

    def get_reward(self, physics: Physics) -> float:
        """1 while the object's lowest point is above the success margin, else 0."""
        return float(physics.object_lowest_z() >= self.config.success_margin_m)


def make_environment(config: TopDrapeConfig, seed: int) -> control.Environment:
    """Build the dm-control environment of one trial."""
    scene = build_scene(config.scene_config(), hub_pos=(0.0, 0.0, 1.0))
    physics = Physics.from_scene(scene)
    task = TopDrape(config, scene.object_info.height_m, seed)
    return control.Environment(
        physics,
        task,
        time_limit=task.schedule.t_end,
        n_sub_steps=config.n_sub_steps,
    )
