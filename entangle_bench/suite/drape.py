"""What the draping task families share: the object, the centering offset and the approach-actuate-settle start.

Top-drape (lift and hold) and pull-out trials begin the same way (Becker et al., PNAS 2022): the hub lowers from
`start_clearance_m` above the object until the straight filament tips would reach `drape_depth_m` below its top
(approach), the pressure ramps to the operating pressure (actuate) and the filaments settle. `DrapePhases` holds
those settings, `DrapeConfig` the object and the centering offset, `DrapeSchedule` the phase times and hub
heights, and `DrapeTask` the episode set-up, the scripted drape and the observation; each family adds what
follows the settle and registers one task per object of the library with `register_object_tasks`.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Callable, Iterable
from dataclasses import astuple, dataclass, field
from typing import Any, ClassVar, Self, TypeVar

import mujoco
from dm_control.rl import control

from entangle_bench import objects
from entangle_bench.config import check_choice, check_range
from entangle_bench.scene import SceneConfig, build_scene
from entangle_bench.suite.base import register_task
from entangle_bench.suite.gripper_task import MAX_HUB_SPEED_M_S, GripperTask, GripperTaskConfig, ScenePhysics

DRAPE_PHASES = ("approach", "actuate", "settle")


@dataclass(frozen=True)
class DrapePhases:
    """Timing and geometry of the scripted drape: approach, pressure ramp, settle (SI units)."""

    start_clearance_m: float = 0.01
    """Gap between the straight filament tips and the object's top at the start, m."""
    drape_depth_m: float = 0.10
    """How far below the object's top the straight filament tips would reach at the end of the approach, m."""
    approach_speed_m_s: float = 0.1
    ramp_time_s: float = 1.0
    """Pressure ramp from 0 to the operating pressure, s."""
    settle_time_s: float = 1.0

    def __post_init__(self) -> None:
        check_range("phases.start_clearance_m", self.start_clearance_m, 0.0, 1.0)
        check_range("phases.drape_depth_m", self.drape_depth_m, 0.0, 1.0)
        check_range("phases.approach_speed_m_s", self.approach_speed_m_s, 0.0, MAX_HUB_SPEED_M_S, low_open=True)
        check_range("phases.ramp_time_s", self.ramp_time_s, 0.0, 60.0)
        check_range("phases.settle_time_s", self.settle_time_s, 0.0, 60.0)


@dataclass(frozen=True)
class DrapeConfig(GripperTaskConfig):
    """A gripper task over one object of the library: the object, the drape sequence and the centering offset."""

    object_name: str = "eight_branch_tree"
    object: Any = None
    """The object's parameter dataclass (None: the object's defaults)."""
    phases: DrapePhases = field(default_factory=DrapePhases)
    offset_m: float = 0.0
    """Centering offset: horizontal distance between the gripper axis and the object axis, m."""
    offset_angle_rad: float | None = None
    """Direction of the offset; None draws it uniformly from the trial seed."""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_choice("object_name", self.object_name, objects.names())
        check_range("offset_m", self.offset_m, 0.0, 1.0)
        if self.offset_angle_rad is not None:
            check_range("offset_angle_rad", self.offset_angle_rad, -2 * math.pi, 2 * math.pi)

    def scene_config(self) -> SceneConfig:
        """The scene: gripper, object and ground."""
        return SceneConfig(
            gripper=self.gripper,
            object_name=self.object_name,
            object_params=self.object,
            effects=self.effects,
            contact=self.contact,
            numerics=self.numerics,
        )


@dataclass(frozen=True)
class DrapeSchedule:
    """Phase boundaries (s) and the hub heights at the start and the end of the approach (m).

    Families add one time field per phase that follows the settle (`AFTER_SETTLE`, each ending at its field, in
    order) and compute them in `after_settle`.
    """

    hub_start_z: float
    hub_drape_z: float
    t_actuate: float
    t_settle: float
    t_settled: float
    """End of the settle: where each family's own sequence begins, s."""

    AFTER_SETTLE: ClassVar[tuple[str, ...]] = ()

    @classmethod
    def from_config(cls, config: DrapeConfig, object_top_m: float) -> Self:
        """Phase times for an object whose top is `object_top_m` above the ground (m)."""
        ph, length = config.phases, config.gripper.filament.length_m
        start = object_top_m + length + ph.start_clearance_m
        drape = object_top_m + length - ph.drape_depth_m
        t_actuate = (start - drape) / ph.approach_speed_m_s
        t_settle = t_actuate + ph.ramp_time_s
        t_settled = t_settle + ph.settle_time_s
        return cls(start, drape, t_actuate, t_settle, t_settled, *cls.after_settle(config, t_settled))

    @classmethod
    def after_settle(cls, config: Any, t_settled: float) -> tuple[float, ...]:
        """End times of the AFTER_SETTLE phases, s (none for the drape alone)."""
        return ()

    def boundaries(self) -> tuple[tuple[str, float], ...]:
        """(phase, end time in s) in order."""
        return tuple(zip((*DRAPE_PHASES, *self.AFTER_SETTLE), astuple(self)[2:]))

    def phase(self, t: float) -> str:
        """Name of the phase at time t (s); 'done' after the last boundary."""
        for name, end in self.boundaries():
            if t < end - 1e-9:
                return name
        return "done"


DC = TypeVar("DC", bound=DrapeConfig)


class DrapeTask(GripperTask[DC]):
    """A gripper task that drapes the filaments over the object, actuates and settles before its own sequence."""

    #: The family's schedule (phase times from the config and the height of the object's top); PHASES follow.
    SCHEDULE: ClassVar[type[DrapeSchedule]] = DrapeSchedule

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.PHASES = (*DRAPE_PHASES, *cls.SCHEDULE.AFTER_SETTLE, "done")

    def __init__(self, config: DC, object_top_m: float, seed: int):
        super().__init__(config, seed)
        self.schedule = self.SCHEDULE.from_config(config, object_top_m)

    @classmethod
    def make_environment(cls, config: DC, seed: int) -> control.Environment:
        """The dm-control environment of one trial, its time limit the end of the schedule's last phase."""
        scene = build_scene(config.scene_config(), hub_pos=(0.0, 0.0, 1.0))
        task = cls(config, scene.config.post_height_m + scene.object_info.height_m, seed)
        return control.Environment(
            ScenePhysics.from_scene(scene),
            task,
            time_limit=task.schedule.boundaries()[-1][1],
            n_sub_steps=config.n_sub_steps,
        )

    def initialize_episode(self, physics: ScenePhysics) -> None:
        """Draw bending planes, offset direction and joint perturbations; place the hub above the object."""
        cfg, model, data = self.config, physics.model.ptr, physics.data.ptr
        self.reset_actuation(physics)
        angle = self.rng.uniform(-math.pi, math.pi) if cfg.offset_angle_rad is None else cfg.offset_angle_rad
        data.mocap_pos[0] = (
            cfg.offset_m * math.cos(angle),
            cfg.offset_m * math.sin(angle),
            self.schedule.hub_start_z,
        )
        self.perturb_joints(physics, cfg.perturbation_rad)
        mujoco.mj_kinematics(model, data)
        super().initialize_episode(physics)

    def drape_action(self, t: float) -> tuple[float, float] | None:
        """(hub vz in m/s, pressure fraction) of the drape at time t (s); None once the settle is over."""
        ph, schedule = self.config.phases, self.schedule
        phase = schedule.phase(t)
        if phase == "approach":
            return -ph.approach_speed_m_s, 0.0
        if phase == "actuate":
            return 0.0, ((t - schedule.t_actuate) / ph.ramp_time_s if ph.ramp_time_s > 0 else 1.0)
        if phase == "settle":
            return 0.0, 1.0
        return None

    def get_observation(self, physics: ScenePhysics) -> collections.OrderedDict:
        """Filament centerlines, hub and object pose, contact counts by kind, pressure."""
        pos, quat = physics.object_pose()
        gripper = self.gripper_observation(physics)
        return collections.OrderedDict(
            centerlines=gripper["centerlines"],
            hub_position=gripper["hub_position"],
            object_position=pos,
            object_quaternion=quat,
            contact_counts=gripper["contact_counts"],
            pressure=gripper["pressure"],
        )


def register_object_tasks(
    domain: str, config_type: type[DC], task_type: type[DrapeTask[DC]], what: str, tags: Iterable[str]
) -> None:
    """Register task `domain/<object>` for every object of the library (mesh objects also tagged 'mesh')."""
    for name in objects.names():
        register_task(
            f"{domain}/{name}",
            config_type=config_type,
            make_environment=task_type.make_environment,
            tags=tuple(tags) + (("mesh",) if objects.is_mesh_object(name) else ()),
            description=f"{what} of {name}: {objects.description(name)}",
        )(_object_default(config_type, name))


def _object_default(config_type: type[DC], object_name: str) -> Callable[[], DC]:
    """Default-config function of one object's task."""

    def default_config() -> DC:
        return config_type(object_name=object_name, object=objects.default_params(object_name))

    return default_config
