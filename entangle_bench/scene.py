"""Scene assembly: gripper + optional object + ground, with declared effects and numerics, compiled to MjModel."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import mujoco
import numpy as np

from entangle_bench import effects as fx
from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.geoms import POST, GeomClasses, role_of
from entangle_bench.gripper import Gripper, GripperParams, add_gripper, filament_positions
from entangle_bench.presets import Numerics


@dataclass(frozen=True)
class ContactParams:
    """Contact material shared by all pairs (SI units)."""

    friction: float = 1.0
    """Sliding friction coefficient (silicone on rigid plastic is of order 1)."""
    filament_friction: float | None = None
    """Sliding friction between filaments (silicone on silicone), None: `friction`. Object and ground geoms
    take priority over filament geoms, so a filament touching them uses `friction` whatever this is."""
    torsional_friction_m: float = 1e-4
    rolling_friction_m: float = 1e-5
    timeconst_s: float = 0.02
    """Contact spring time constant (MuJoCo solref[0]); must be at least twice the timestep."""
    dampratio: float = 1.0
    impedance: tuple[float, float] = (0.9, 0.95)
    """MuJoCo solimp[0:2]: impedance d at zero penetration and from 1 mm on (MuJoCo's defaults). A contact
    follows its spring (`timeconst_s`) with weight d and lets 1 - d of the unconstrained acceleration a0
    through, so a contact pushed with a0 settles at a depth r = (1 - d) a0 (timeconst dampratio)^2 (d = d1)."""

    def __post_init__(self) -> None:
        check_range("contact.friction", self.friction, 0.0, 10.0)
        if self.filament_friction is not None:
            check_range("contact.filament_friction", self.filament_friction, 0.0, 10.0)
        check_range("contact.torsional_friction_m", self.torsional_friction_m, 0.0, 1.0)
        check_range("contact.rolling_friction_m", self.rolling_friction_m, 0.0, 1.0)
        check_range("contact.timeconst_s", self.timeconst_s, 0.0, 1.0, low_open=True)
        check_range("contact.dampratio", self.dampratio, 0.0, 10.0, low_open=True)
        low, high = self.impedance
        if not 0.0 < low <= high < 1.0:
            raise ParameterError(f"contact.impedance = {self.impedance} must satisfy 0 < d0 <= d1 < 1 (MuJoCo solimp)")


@dataclass(frozen=True)
class SceneConfig:
    """Everything that defines a compiled scene except the initial poses."""

    gripper: GripperParams = field(default_factory=GripperParams)
    object_name: str | None = None
    """Object from the object library, or None for the gripper alone in free air."""
    object_params: Any = None
    """The object's own parameter dataclass; None means its defaults."""
    effects: fx.Effects = field(default_factory=fx.Effects)
    contact: ContactParams = field(default_factory=ContactParams)
    numerics: Numerics = field(default_factory=Numerics)
    object_weld: Literal["none", "world", "hub"] = "none"
    """A weld equality (OBJECT_WELD, inactive until switched on) holding the object to the world or the hub."""
    post_height_m: float = 0.0
    """Height of a fixed vertical post (a geom of the ground, `POST`) whose top the object is placed on, m; 0: no
    post, the object stands on the ground."""
    post_radius_m: float = 0.005
    """Radius of that post, m; 0: no post geom, the object is placed at that height with nothing under it."""

    def __post_init__(self) -> None:
        check_choice("object_weld", self.object_weld, ("none", "world", "hub"))
        check_range("post_height_m", self.post_height_m, 0.0, 1.0)
        check_range("post_radius_m", self.post_radius_m, 0.0, 0.1)
        self.numerics.check_joints(self.gripper.filament.joints)
        if self.object_weld != "none" and self.object_name is None:
            raise ParameterError(f"object_weld = {self.object_weld!r} needs an object; the scene has none")
        if self.post_height_m > 0 and self.object_name is None:
            raise ParameterError(f"post_height_m = {self.post_height_m} needs an object to hold; the scene has none")
        if self.post_height_m > 0 and self.post_radius_m == 0 and self.object_weld == "none":
            raise ParameterError(f"post_height_m = {self.post_height_m} with post_radius_m = 0 leaves the object in "
                                 "mid-air: it needs object_weld 'world' to hold it")


#: Name of the equality that welds the object to its holder (`SceneConfig.object_weld`).
OBJECT_WELD = "object_weld"


@dataclass
class Scene:
    """A compiled scene with its named parts."""

    config: SceneConfig
    model: mujoco.MjModel
    gripper: Gripper
    object_info: Any
    geoms: GeomClasses
    """Filament, object and ground flags of every geom (`entangle_bench.geoms`)."""

    @property
    def object_body(self) -> int:
        """Body id of the object, -1 if the scene has none."""
        return self.model.body("object").id if self.object_info is not None else -1

    @property
    def object_weld(self) -> int:
        """Equality id of the object's weld (OBJECT_WELD), -1 if the scene has none."""
        return self.model.equality(OBJECT_WELD).id if self.config.object_weld != "none" else -1


def build_scene(
    config: SceneConfig,
    hub_pos: tuple[float, float, float] = (0.0, 0.0, 0.5),
    object_pos: tuple[float, float, float] | None = None,
    object_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0),
) -> Scene:
    """Assemble and compile the scene; invalid parameters raise before anything is compiled.

    `object_pos` is the object's base point (m): on the ground by default, on the post's top with one.
    """
    contact = config.contact
    check_range(
        "contact.timeconst_s (relative to 2 * numerics.timestep_s)",
        contact.timeconst_s,
        2.0 * config.numerics.timestep_s,
        None,
    )
    spec = mujoco.MjSpec()
    spec.modelname = "entangle_bench"
    config.numerics.apply(spec)
    spec.worldbody.add_light(pos=(0, 0, 1.5), dir=(0, 0, -1))
    spec.worldbody.add_geom(
        name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=(1.0, 1.0, 0.01), rgba=(0.8, 0.8, 0.8, 1)
    )
    post = config.post_height_m
    if post > 0 and config.post_radius_m > 0:
        spec.worldbody.add_geom(
            name=POST, type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=(config.post_radius_m, post / 2, 0.0),
            pos=(0.0, 0.0, post / 2), rgba=(0.5, 0.5, 0.5, 1),
        )
    gripper = add_gripper(
        spec, config.gripper, hub_pos, twist_armature_scale=config.numerics.twist_armature_scale,
        bending_armature=config.numerics.bending_armature,
    )
    info = None
    if config.object_name is not None:
        from entangle_bench import objects

        info = objects.add_object(
            spec, config.object_name, config.object_params, pos=(0.0, 0.0, post) if object_pos is None else object_pos,
            quat=object_quat,
        )
    if config.object_weld != "none":
        # Inactive at first; the task sets its relative pose and switches it on (`ScenePhysics.clamp_object`).
        # The stiffest stable constraint (time constant 2 dt): the object sags by about g (2 dt)^2 under its weight.
        spec.add_equality(
            name=OBJECT_WELD,
            type=mujoco.mjtEq.mjEQ_WELD,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1="object",
            name2="hub" if config.object_weld == "hub" else "world",
            active=False,
            solref=(2.0 * config.numerics.timestep_s, 1.0),
        )
    collision_group = {"ground": fx.GROUND, "object": fx.OBJECT, "filament": fx.FILAMENT}
    roles = {geom.name: role_of(geom.name)[0] for geom in spec.geoms}
    group = {name: collision_group[role] for name, role in roles.items() if role in collision_group}
    # Material first: explicit contact pairs made by apply_effects copy it from the geoms.
    filament_friction = contact.friction if contact.filament_friction is None else contact.filament_friction
    for geom in spec.geoms:
        # MuJoCo takes a contact's material from the geom of higher priority (the larger friction at equal
        # priority): object and ground over filaments, so only filament pairs use the filament friction.
        is_filament = roles.get(geom.name) == "filament"
        geom.priority = 0 if is_filament else 1
        sliding = filament_friction if is_filament else contact.friction
        geom.friction = (sliding, contact.torsional_friction_m, contact.rolling_friction_m)
        geom.solref = (contact.timeconst_s, contact.dampratio)
        geom.solimp = (*contact.impedance, 0.001, 0.5, 2.0)
    fx.apply_effects(
        spec,
        config.effects,
        group,
        [list(h.body_names) for h in gripper.filaments],
        filament_positions(config.gripper),
        config.gripper.filament.length_m + config.gripper.filament.outer_radius_m,
        body_volumes_m3=None if info is None else {"object": info.volume_m3},
    )
    model = spec.compile()
    gripper.bind(model)
    return Scene(config, model, gripper, info, GeomClasses.from_model(model))


def kinetic_energy(model: mujoco.MjModel, data: mujoco.MjData) -> float:
    """0.5 qvel^T M qvel, J (uses the mass matrix of the last step)."""
    out = np.empty(model.nv)
    mujoco.mj_mulM(model, data, out, data.qvel)
    return 0.5 * float(data.qvel @ out)


def step_until_rest(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    max_time_s: float,
    speed_tol_m_s: float = 1e-4,
    kinetic_damping: bool = False,
) -> bool:
    """Step until every body's linear speed stays below `speed_tol_m_s` for 0.2 s; True if so in `max_time_s`.

    With `kinetic_damping` this is dynamic relaxation (Day 1965; Cundall 1976): whenever the kinetic energy
    passes a peak, all velocities are zeroed, so every mode loses its energy within half a period and the
    state walks to the nearest static equilibrium. Only for statics: it is not a dynamic simulation.
    """
    check_every = max(1, int(0.01 / model.opt.timestep))
    start = data.time
    last_ke = 0.0
    calm_since = None
    while data.time - start < max_time_s:
        for _ in range(check_every):
            mujoco.mj_step(model, data)
            if kinetic_damping:
                ke = kinetic_energy(model, data)
                if ke < last_ke:
                    data.qvel[:] = 0.0
                    ke = 0.0
                last_ke = ke
        if not np.all(np.isfinite(data.qvel)):
            return False
        if np.max(np.abs(data.cvel[1:, 3:])) >= speed_tol_m_s:
            calm_since = None
        elif calm_since is None:
            calm_since = data.time
        elif data.time - calm_since >= 0.2:
            return True
    return False
