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
from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.geoms import KINDS, lowest_z
from entangle_bench.gripper import GripperParams, bending_angles
from entangle_bench.metrics.acn import acn_total
from entangle_bench.metrics.contacts import ContactSummary, ObjectSupport, contact_summary, object_support
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.presets import PER_PHASE_OPTIONS, Numerics
from entangle_bench.scene import ContactParams, Scene, SceneConfig
from entangle_bench.suite.base import BenchTask, Snapshot
from entangle_bench.viz import object_geometry, pack
from entangle_bench.watchdog import mechanical_energy

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
        self.numerics.check_joints(self.gripper.filament.joints)

    @property
    def n_sub_steps(self) -> int:
        """Physics steps per control step: the control timestep rounded to whole physics steps."""
        return max(1, round(self.control_timestep_s / self.numerics.timestep_s))

    def scene_config(self) -> SceneConfig:
        """The scene: the gripper alone (task families with an object add it)."""
        return SceneConfig(gripper=self.gripper, effects=self.effects, contact=self.contact, numerics=self.numerics)


G = TypeVar("G", bound=GripperTaskConfig)


@dataclass
class EnergyLedger:
    """Work and losses summed over every physics step since the ledger started, J.

    Each step adds dt times: the hub force on the filament roots (from the step's forward pass) . hub velocity;
    the damper power -qfrc_damper . qvel; the constraint power qfrc_constraint . qvel plus, since the filaments'
    joint velocities leave out the hub's motion, the constraint force on the filaments . hub velocity. Velocities
    are those the step ends with, so each term is a force times the step's displacement (qvel holds the
    filaments' motion relative to the moving hub). First order in dt and
    consistent with explicit integration (implicit integrators damp with the velocity the step ends with). Then
    hub work = change of mechanical energy + damper loss - constraint work.
    """

    roots: np.ndarray
    """(nbody,) 1 for the filament root segments, else 0."""
    filaments: np.ndarray
    """(nbody,) 1 for every filament segment, else 0."""
    hub_work_j: float = 0.0
    """Work the hub did on the filaments, J."""
    damping_loss_j: float = 0.0
    """Energy the joint dampers dissipated, J (>= 0)."""
    constraint_work_j: float = 0.0
    """Work of the constraint forces (contacts, weld), J (< 0: they dissipated)."""

    def book(self, model: mujoco.MjModel, data: mujoco.MjData, hub_velocity: np.ndarray, dt: float) -> None:
        """Add the physics step just taken (mj_step; hub moving at `hub_velocity`, m/s; step dt, s)."""
        mujoco.mj_rnePostConstraint(model, data)  # cfrc_int: force from each parent; cfrc_ext: constraint force
        hub_force = (self.roots @ data.cfrc_int)[3:]
        on_filaments = (self.filaments @ data.cfrc_ext)[3:]
        qvel = data.qvel
        self.hub_work_j += dt * float(hub_force @ hub_velocity)
        self.damping_loss_j -= dt * float(data.qfrc_damper @ qvel)
        self.constraint_work_j += dt * float(data.qfrc_constraint @ qvel + on_filaments @ hub_velocity)


class ScenePhysics(dm_mujoco.Physics):
    """MuJoCo physics of a scene with named read-outs; the hub moves at `hub_velocity` (m/s) each substep."""

    scene: Scene
    hub_velocity: np.ndarray
    ledger: EnergyLedger | None
    """Energy bookkeeping over the physics steps, once `start_ledger` was called (None before)."""
    _conaffinity: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> ScenePhysics:
        """Wrap a compiled scene."""
        physics = cls.from_model(dm_mujoco.wrapper.MjModel(scene.model))
        physics.scene = scene
        physics.hub_velocity = np.zeros(3)
        physics.ledger = None
        physics._conaffinity = physics.model.ptr.geom_conaffinity.copy()
        return physics

    def step(self, nstep: int = 1) -> None:
        """Advance `nstep` physics steps, moving the mocap hub by hub_velocity * dt before each (and book energy)."""
        model, data = self.model.ptr, self.data.ptr
        dt = model.opt.timestep
        with self.check_invalid_state():
            for _ in range(nstep):
                data.mocap_pos[0] += self.hub_velocity * dt
                mujoco.mj_step(model, data)
                if self.ledger is not None:
                    self.ledger.book(model, data, self.hub_velocity, dt)

    def start_ledger(self) -> EnergyLedger:
        """Start (or restart) the energy bookkeeping from zero (`unclamp_object` stops it)."""
        gripper, nbody = self.scene.gripper, self.model.ptr.nbody
        roots, filaments = np.zeros(nbody), np.zeros(nbody)
        roots[gripper.root_body_ids] = 1.0
        filaments[gripper.body_ids] = 1.0
        self.ledger = EnergyLedger(roots, filaments)
        return self.ledger

    def hub_position(self) -> np.ndarray:
        """Hub position, m."""
        return self.data.mocap_pos[0].copy()

    def object_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Object position (m) and quaternion."""
        body = self.scene.object_body
        return self.data.xpos[body].copy(), self.data.xquat[body].copy()

    def object_orientation_free(self) -> bool:
        """Whether every orientation of the object is the same object (a ball)."""
        return self.scene.object_info is not None and self.scene.object_info.orientation_free

    def object_lowest_z(self) -> float:
        """Height of the object's lowest surface point (`geoms.lowest_z`), m."""
        return lowest_z(self.model.ptr, self.data.ptr, np.flatnonzero(self.scene.geoms.is_object))

    def centerlines(self) -> np.ndarray:
        """(F, n + 1, 3) filament centerlines, m."""
        return self.scene.gripper.centerlines(self.model.ptr, self.data.ptr)

    def contact_counts(self, active_only: bool = False) -> dict[str, int]:
        """Contacts MuJoCo detected (within margin; only those with constraint rows if asked), by kind of KINDS."""
        data = self.data.ptr
        pairs = data.contact.geom[: data.ncon]
        if active_only:
            pairs = pairs[data.contact.efc_address[: data.ncon] >= 0]
        return self.scene.geoms.count_kinds(pairs)

    def clamp_object(self) -> None:
        """Switch on the object's weld (`SceneConfig.object_weld`) where the object is now; take it off the ground.

        The weld's anchor is the object's center of mass and its relative pose the current one (`model.eq_data`:
        anchor in the holder's frame, the holder's pose in the object's frame), so nothing jumps; the holder,
        not the ground, then carries the object (object-ground contact off until `unclamp_object`).
        """
        model, data = self.model.ptr, self.data.ptr
        weld = self.scene.object_weld
        if weld < 0:
            raise ParameterError("this scene has no object weld (SceneConfig.object_weld = 'none')")
        body, holder = model.eq_obj1id[weld], model.eq_obj2id[weld]
        holder_rot = data.xmat[holder].reshape(3, 3)
        model.eq_data[weld, 0:3] = holder_rot.T @ (data.xipos[body] - data.xpos[holder])
        model.eq_data[weld, 3:6] = model.body_ipos[body]
        inverse = np.empty(4)
        mujoco.mju_negQuat(inverse, data.xquat[body])
        mujoco.mju_mulQuat(model.eq_data[weld, 6:10], inverse, data.xquat[holder])
        data.eq_active[weld] = 1
        geoms = self.scene.geoms
        model.geom_conaffinity[geoms.is_object] &= ~fx.GROUND
        model.geom_conaffinity[geoms.is_ground] &= ~fx.OBJECT

    def unclamp_object(self) -> None:
        """Switch the object's weld off (if the scene has one), restore the object-ground contact, stop the ledger."""
        self.ledger = None
        if self.scene.object_weld >= 0:
            self.data.ptr.eq_active[self.scene.object_weld] = 0
        self.model.ptr.geom_conaffinity[:] = self._conaffinity

    def object_weld_force(self) -> np.ndarray:
        """(3,) force the object's weld exerts on the object, world frame, N (zero while off).

        The weld's first three constraint rows (`efc_type` equality, `efc_id` the weld) hold the force on its
        first body, the object, in world axes at the anchor (tested against a hanging object's weight).
        """
        data = self.data.ptr
        rows = np.flatnonzero(
            (data.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (data.efc_id == self.scene.object_weld)
        )
        return data.efc_force[rows[:3]].copy() if len(rows) else np.zeros(3)

    def object_support(self) -> ObjectSupport:
        """Forces on the object by source (filaments by part, pinches, ground), world frame, N."""
        return object_support(self.model.ptr, self.data.ptr, self.scene.geoms)

    def object_weight(self) -> np.ndarray:
        """(3,) gravity force on the object, world frame, N (zero without gravity or object)."""
        model = self.model.ptr
        if self.scene.object_body < 0 or model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
            return np.zeros(3)
        return model.body_mass[self.scene.object_body] * model.opt.gravity.copy()

    def hub_force(self) -> np.ndarray:
        """(3,) force the hub exerts on the filament roots, world frame, N (runs `mj_rnePostConstraint`).

        `cfrc_int` of a root segment is the force its parent, the hub, exerts on it (tested: a filament hanging
        at rest needs + its weight).
        """
        model, data = self.model.ptr, self.data.ptr
        mujoco.mj_rnePostConstraint(model, data)
        return data.cfrc_int[self.scene.gripper.root_body_ids, 3:].sum(axis=0)

    def mechanical_energy_j(self) -> float:
        """Gravity, spring and kinetic energy of the bodies that move dynamically, J (the mocap hub left out).

        Of the current positions and velocities: recomputes kinematics and the mass matrix only, so the forces
        and contacts of the last step's forward pass (what the other read-outs report) stay as they were.
        """
        model, data = self.model.ptr, self.data.ptr
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_makeM(model, data)
        energy = mechanical_energy(model, data)
        if not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY:
            mocap = model.body_mocapid >= 0
            energy += float(np.sum(model.body_mass[mocap] * (data.xipos[mocap] @ model.opt.gravity)))
        return energy


class GripperTask(BenchTask[G]):
    """A task driving the filament gripper: action hub velocity (m/s, 3) and pressure fraction (0..1)."""

    def __init__(self, config: G, seed: int):
        super().__init__(config, seed)
        for field_name, _ in PER_PHASE_OPTIONS.values():
            for name in getattr(config.numerics, field_name):
                check_choice(f"numerics.{field_name}", name, self.PHASES)
        self.angles = np.zeros(config.gripper.n_filaments)
        self._pressure_fraction = 0.0

    def reset_actuation(self, physics: ScenePhysics) -> None:
        """Draw each filament's bending-plane azimuth from the seed; pressure 0 (straight rest shape), hub at rest."""
        self.angles = bending_angles(self.config.gripper, self.rng)
        physics.scene.gripper.set_pressure(physics.model.ptr, 0.0, self.angles)
        physics.hub_velocity[:] = 0.0
        self._pressure_fraction = 0.0

    def perturb_joints(self, physics: ScenePhysics, std_rad: float) -> None:
        """Rotate every filament joint at random (normal, `std_rad` per axis) from the seed."""
        physics.scene.gripper.joints.perturb(physics.data.ptr, self.rng, std_rad)

    def action_spec(self, physics: ScenePhysics) -> specs.BoundedArray:
        """Hub velocity (m/s, 3) and pressure fraction (0..1)."""
        v = MAX_HUB_SPEED_M_S
        return specs.BoundedArray(
            (4,), np.float64, minimum=(-v, -v, -v, 0.0), maximum=(v, v, v, 1.0), name="hub_velocity_pressure"
        )

    def before_step(self, action: np.ndarray, physics: ScenePhysics) -> None:
        """Set the hub velocity and the shared pressure, and the per-phase solver options for this phase
        (`Numerics.phase_options`: noslip only in `noslip_phases`, impratio only in `impratio_phases`)."""
        for option, value in self.config.numerics.phase_options(self.phase(physics)).items():
            setattr(physics.model.opt, option, value)
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
        """The entanglement of the current state (`entanglement_snapshot`), with the object's parts (`viz.pack`)
        among the arrays so that scripts/plot_entanglement.py draws the object."""
        model, data = physics.model.ptr, physics.data.ptr
        snap = entanglement_snapshot(physics.centerlines(), contact_summary(model, data, physics.scene.geoms))
        parts = pack(object_geometry(model, data, physics.scene.geoms.is_object))
        return Snapshot(snap.metrics, {**snap.arrays, **parts})


def entanglement_snapshot(curves: np.ndarray, contacts: ContactSummary) -> Snapshot:
    """ACN, local fields (spheres of LOCAL_ACN_DIAMETER_M) and active contacts by kind of one state.

    `curves` (F, n + 1, 3) filament centerlines, m. Arrays: `curves`, `contact_points` (c, 3) m, `contact_kinds`
    (c,), `contact_forces_n` (c,) N: the input of scripts/plot_entanglement.py.
    """
    fields = local_fields(curves, LOCAL_ACN_DIAMETER_M)
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
    }
    return Snapshot(metrics, arrays)
