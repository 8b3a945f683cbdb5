"""What every filament-gripper task shares: the physics with named read-outs and the hub-and-pressure task.

`ScenePhysics` wraps a compiled `scene.Scene`; the hub is a mocap body moved at `hub_velocity` each substep.
`GripperTask` is the `BenchTask` whose action is hub velocity (m/s, 3) plus the pressure as a fraction of the
operating pressure: it draws the filaments' bending planes and joint perturbations from the task's seeded
generator, switches the rest shape when the pressure changes, and takes entanglement snapshots (ACN, local
fields, contacts). Its configuration derives from `GripperTaskConfig` (gripper, effects, contact, numerics,
perturbation, control period), so presets and `--set` paths work the same for every gripper task.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass, field
from typing import Any, TypeVar

import mujoco
import numpy as np
from dm_control import mujoco as dm_mujoco
from dm_env import specs

from entangle_bench import effects as fx
from entangle_bench.config import check_range
from entangle_bench.geoms import KINDS
from entangle_bench.gripper import GripperParams, bending_angles
from entangle_bench.metrics.acn import acn_total
from entangle_bench.metrics.contacts import contact_summary
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.presets import Numerics
from entangle_bench.scene import ContactParams, Scene, SceneConfig
from entangle_bench.suite.base import BenchTask, Snapshot
from entangle_bench.viz import object_geometry, pack

MAX_HUB_SPEED_M_S = 2.0

#: Diameter of the spheres of the local ACN and filament-count fields in snapshots, m.
LOCAL_ACN_DIAMETER_M = 0.02


@dataclass(frozen=True)
class GripperTaskConfig:
    """What every gripper task's configuration holds: the gripper scene and the control period (SI units)."""

    gripper: GripperParams = field(default_factory=GripperParams)
    effects: fx.Effects = field(default_factory=fx.Effects)
    contact: ContactParams = field(default_factory=ContactParams)
    numerics: Numerics = field(default_factory=Numerics)
    perturbation_rad: float = 0.01
    """Standard deviation of the random initial joint rotations of the filaments, rad."""
    control_timestep_s: float = 0.01
    """Target control (and watchdog) period, s; rounded to a whole number of physics steps."""

    def __post_init__(self) -> None:
        check_range("perturbation_rad", self.perturbation_rad, 0.0, 0.5)
        check_range("control_timestep_s", self.control_timestep_s, 1e-4, 0.1)

    @property
    def n_sub_steps(self) -> int:
        """Physics steps per control step: the control timestep rounded to whole physics steps."""
        return max(1, round(self.control_timestep_s / self.numerics.timestep_s))

    def scene_config(self) -> SceneConfig:
        """The scene: the gripper alone (task families with an object add it)."""
        return SceneConfig(gripper=self.gripper, effects=self.effects, contact=self.contact, numerics=self.numerics)


G = TypeVar("G", bound=GripperTaskConfig)


class ScenePhysics(dm_mujoco.Physics):
    """MuJoCo physics of a scene with named read-outs; the hub moves at `hub_velocity` (m/s) each substep."""

    scene: Scene
    hub_velocity: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> ScenePhysics:
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
        ids = np.flatnonzero(self.scene.geoms.is_object)
        rot = data.geom_xmat[ids].reshape(-1, 3, 3)
        center = data.geom_xpos[ids] + np.einsum("gij,gj->gi", rot, model.geom_aabb[ids, :3])
        reach = np.einsum("gj,gj->g", np.abs(rot[:, 2, :]), model.geom_aabb[ids, 3:])
        return float(np.min(center[:, 2] - reach))

    def centerlines(self) -> np.ndarray:
        """(F, n + 1, 3) filament centerlines, m."""
        return self.scene.gripper.centerlines(self.model.ptr, self.data.ptr)

    def contact_counts(self) -> dict[str, int]:
        """Contacts MuJoCo detected (within margin, active or not), by kind of `geoms.KINDS`."""
        data = self.data.ptr
        return self.scene.geoms.count_kinds(data.contact.geom[: data.ncon])


class GripperTask(BenchTask[G]):
    """A task driving the filament gripper: action hub velocity (m/s, 3) and pressure fraction (0..1)."""

    def __init__(self, config: G, seed: int):
        super().__init__(config, seed)
        self.angles = np.zeros(config.gripper.n_filaments)
        self._pressure_fraction = 0.0

    def reset_actuation(self, physics: ScenePhysics) -> None:
        """Draw each filament's bending-plane azimuth from the seed; pressure 0 (straight rest shape), hub at rest."""
        self.angles = bending_angles(self.config.gripper, self.rng)
        physics.scene.gripper.set_pressure(physics.model.ptr, 0.0, self.angles)
        physics.hub_velocity[:] = 0.0
        self._pressure_fraction = 0.0

    def perturb_joints(self, physics: ScenePhysics, std_rad: float) -> None:
        """Rotate every filament joint by a random rotation vector (normal, `std_rad` per axis) from the seed."""
        data = physics.data.ptr
        adr = physics.scene.gripper.spring_addresses.reshape(-1, 4)
        rotvec = self.rng.normal(0.0, std_rad, size=(len(adr), 3))
        quat = np.empty(4)
        for row, vec in zip(adr, rotvec):
            angle = float(np.linalg.norm(vec))
            mujoco.mju_axisAngle2Quat(quat, vec / (angle + 1e-300), angle)
            data.qpos[row] = quat  # `row` is an index array: data.qpos[row] on the right would be a copy

    def action_spec(self, physics: ScenePhysics) -> specs.BoundedArray:
        """Hub velocity (m/s, 3) and pressure fraction (0..1)."""
        v = MAX_HUB_SPEED_M_S
        return specs.BoundedArray(
            (4,), np.float64, minimum=(-v, -v, -v, 0.0), maximum=(v, v, v, 1.0), name="hub_velocity_pressure"
        )

    def before_step(self, action: np.ndarray, physics: ScenePhysics) -> None:
        """Set the hub velocity and the shared pressure."""
        action = np.asarray(action, dtype=float)
        physics.hub_velocity[:] = np.clip(action[:3], -MAX_HUB_SPEED_M_S, MAX_HUB_SPEED_M_S)
        fraction = float(np.clip(action[3], 0.0, 1.0))
        if fraction != self._pressure_fraction:
            self._pressure_fraction = fraction
            physics.scene.gripper.set_pressure(
                physics.model.ptr, fraction * self.config.gripper.pressure_pa, self.angles
            )

    @property
    def pressure_pa(self) -> float:
        """Current commanded pressure, Pa."""
        return self._pressure_fraction * self.config.gripper.pressure_pa

    def actuation_energy_j(self) -> float:
        """Bending energy 0.5 EI kappa^2 L of all filaments at full pressure, J."""
        return self.config.gripper.actuation_energy_j

    def gripper_observation(self, physics: ScenePhysics) -> collections.OrderedDict:
        """Filament centerlines (m), hub position (m), contact counts by kind, pressure (Pa)."""
        counts = physics.contact_counts()
        return collections.OrderedDict(
            centerlines=physics.centerlines().ravel(),
            hub_position=physics.hub_position(),
            contact_counts=np.array([counts[k] for k in KINDS], dtype=float),
            pressure=np.array([self.pressure_pa]),
        )

    def get_observation(self, physics: ScenePhysics) -> collections.OrderedDict:
        """The gripper's observation (see `gripper_observation`)."""
        return self.gripper_observation(physics)

    def snapshot(self, physics: Any) -> Snapshot:
        """ACN, local fields (spheres of LOCAL_ACN_DIAMETER_M) and active contacts by kind; curves and contacts.

        Arrays: `curves` (F, n + 1, 3) m, `contact_points` (c, 3) m, `contact_kinds` (c,), `contact_forces_n`
        (c,) N, and the object's parts (`viz.pack`): the input of scripts/plot_entanglement.py.
        """
        curves = physics.centerlines()
        fields = local_fields(curves, LOCAL_ACN_DIAMETER_M)
        contacts = contact_summary(physics.model.ptr, physics.data.ptr, physics.scene.geoms)
        metrics = {
            "acn_total": acn_total(curves),
            "local_acn_mean": fields.mean_acn,
            "local_acn_max": fields.max_acn,
            "local_count_mean": fields.mean_count,
        }
        metrics.update({f"contacts.{k}": v for k, v in contacts.counts.items()})
        arrays = {
            "curves": curves,
            "contact_points": contacts.points,
            "contact_kinds": contacts.kinds,
            "contact_forces_n": contacts.normal_forces_n,
            **pack(object_geometry(physics.model.ptr, physics.data.ptr, physics.scene.geoms.is_object)),
        }
        return Snapshot(metrics, arrays)
