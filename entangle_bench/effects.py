"""Physical effects a scene declares; the compiled model contains only those.

Collision groups use MuJoCo's contype/conaffinity bit masks: each geom's contype is its own group
bit and its conaffinity is the set of groups it may touch, so two geoms collide only if the declared
effects allow the pair (MuJoCo collides a pair when contype1 & conaffinity2 or contype2 &
conaffinity1 is non-zero); a group that may touch nothing gets contype = conaffinity = 0 and leaves
the broad phase altogether. Finer rules (self-contact, filaments that can never reach each other)
become explicit body excludes or explicit pairs. Adjacent segments of a filament never collide:
MuJoCo's parent filter drops parent-child body pairs. The hub has no collision geom (contype =
conaffinity = 0), so nothing is ever tested against it.

Engine stages nobody needs are switched off with disable flags (gravity, contact, the whole
constraint stage when nothing can constrain, friction loss, limits, equality, actuation, damping),
and the fluid model is compiled in only for aquatic scenes. MuJoCo's fluid models give drag and lift
but no buoyancy (MuJoCo documentation, "Fluid forces"); buoyancy is added as gravity compensation,
an upward force rho_medium V g at each body's center of mass (`body_gravcomp` = rho_medium V / m).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Literal

import mujoco
import numpy as np
from scipy.spatial import ConvexHull

from entangle_bench.config import check_choice, check_range
from entangle_bench.filament import FilamentParams
from entangle_bench.geoms import GeomClasses

GROUND, OBJECT, FILAMENT = 1, 2, 4
CONDIM = {"none": 1, "sliding": 3, "torsional": 4, "rolling": 6}


@dataclass(frozen=True)
class Effects:
    """Which physics a scene simulates. Everything off costs nothing."""

    gravity: bool = True
    filament_filament_contact: bool = True
    filament_self_contact: bool = True
    filament_object_contact: bool = True
    ground_contact: bool = True
    friction: Literal["none", "sliding", "torsional", "rolling"] = "sliding"
    """Friction model: contact dimension 1, 3, 4 or 6."""
    cone: Literal["pyramidal", "elliptic"] = "pyramidal"
    joint_damping: bool = True
    aquatic: bool = False
    """Immerse the scene in a fluid: buoyancy plus MuJoCo's ellipsoid fluid model (drag, lift)."""
    medium_density_kg_m3: float = 1000.0
    medium_viscosity_pa_s: float = 1.0e-3

    def __post_init__(self) -> None:
        check_choice("effects.friction", self.friction, tuple(CONDIM))
        check_choice("effects.cone", self.cone, ("pyramidal", "elliptic"))
        check_range("effects.medium_density_kg_m3", self.medium_density_kg_m3, 0.0, 2e4)
        check_range("effects.medium_viscosity_pa_s", self.medium_viscosity_pa_s, 0.0, 1e3)

    @property
    def any_contact(self) -> bool:
        """True if any contact effect is on."""
        return (
            self.filament_filament_contact
            or self.filament_self_contact
            or self.filament_object_contact
            or self.ground_contact
        )

    def summary(self) -> dict[str, object]:
        """Effect name -> setting, for tables and `describe`."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


#: Gravity without any contact: a rod with nothing to touch.
NO_CONTACT = Effects(
    filament_filament_contact=False,
    filament_self_contact=False,
    filament_object_contact=False,
    ground_contact=False,
)

#: No contact, no gravity: an isolated rod.
ISOLATED = dataclasses.replace(NO_CONTACT, gravity=False)

#: Effects that are on by default and can be switched off, with their "off" setting.
OPTIONAL_EFFECTS: dict[str, object] = {
    "gravity": False,
    "filament_filament_contact": False,
    "filament_self_contact": False,
    "filament_object_contact": False,
    "ground_contact": False,
    "friction": "none",
    "joint_damping": False,
}


def switched_off(effects: Effects, name: str) -> Effects:
    """Copy of `effects` with the optional effect `name` (a key of OPTIONAL_EFFECTS) off."""
    check_choice("optional effect", name, tuple(OPTIONAL_EFFECTS))
    return dataclasses.replace(effects, **{name: OPTIONAL_EFFECTS[name]})


def affinity(effects: Effects) -> dict[int, int]:
    """Collision group bit -> conaffinity mask allowed by the effects."""
    ground = (OBJECT | FILAMENT) if effects.ground_contact else 0
    obj = (GROUND if effects.ground_contact else 0) | (
        FILAMENT if effects.filament_object_contact else 0
    )
    fil = (GROUND if effects.ground_contact else 0) | (
        OBJECT if effects.filament_object_contact else 0
    )
    if effects.filament_filament_contact:
        fil |= FILAMENT
    return {GROUND: ground, OBJECT: obj, FILAMENT: fil}


def submerged_weight_fraction(filament: FilamentParams, effects: Effects) -> float:
    """Net weight of the filament in its medium over its weight in vacuum (1 in air, < 0: floats).

    The sealed channel holds the actuation gas, so the filament displaces its whole outer volume.
    """
    if not effects.aquatic:
        return 1.0
    displaced = math.pi * filament.outer_radius_m**2 * effects.medium_density_kg_m3
    return 1.0 - displaced / filament.linear_density_kg_m


def gravity_length_m(filament: FilamentParams, effects: Effects) -> float:
    """Elasto-gravity length l_g = (EI / (|Delta(rho A)| g))^(1/3) in the scene's medium, m.

    Infinite without gravity or net weight. With a solid section this is the
    l_g = (E r^2 / (Delta rho g))^(1/3) scaling of the reference design (Becker et al., PNAS 2022);
    l / l_g measures how much the filament droops under its net weight.
    """
    net = abs(submerged_weight_fraction(filament, effects)) * filament.linear_density_kg_m
    if not effects.gravity or net == 0.0:
        return math.inf
    return (filament.bending_stiffness_nm2 / (net * 9.81)) ** (1 / 3)


def apply_effects(
    spec: mujoco.MjSpec,
    effects: Effects,
    geom_group: dict[str, int],
    filament_bodies: list[list[str]],
    filament_roots_m: np.ndarray,
    filament_reach_m: float,
    body_volumes_m3: Mapping[str, float] | None = None,
) -> None:
    """Set collision masks, friction model, excludes, disable flags and fluid on a `spec`.

    `geom_group` maps every colliding geom name to GROUND, OBJECT or FILAMENT; other geoms never
    collide. `filament_bodies[i]` lists filament i's segment bodies root to tip; `filament_roots_m`
    (F, 2) the root positions; two filaments whose roots are more than 2 * `filament_reach_m` apart
    can never touch. `body_volumes_m3` gives the displaced volume of bodies (m^3) for buoyancy in
    aquatic scenes; bodies not listed use the sum of their collision geoms' volumes (filament
    segments: the cylinder of the chain).
    """
    masks = affinity(effects)
    condim = CONDIM[effects.friction]
    for geom in spec.geoms:
        group = geom_group.get(geom.name)
        if group is None or masks[group] == 0:
            geom.contype, geom.conaffinity = 0, 0
            continue
        geom.contype = group
        geom.conaffinity = masks[group]
        geom.condim = condim
    if effects.filament_filament_contact and not effects.filament_self_contact:
        for bodies in filament_bodies:
            for j in range(len(bodies)):
                for k in range(j + 2, len(bodies)):
                    spec.add_exclude(bodyname1=bodies[j], bodyname2=bodies[k])
    if effects.filament_self_contact and not effects.filament_filament_contact:
        for bodies in filament_bodies:
            for j in range(len(bodies)):
                for k in range(j + 2, len(bodies)):
                    _add_filament_pair(spec, _geom_of(bodies[j]), _geom_of(bodies[k]), condim)
    if effects.filament_filament_contact:
        for a in range(len(filament_bodies)):
            for b in range(a + 1, len(filament_bodies)):
                gap = np.linalg.norm(filament_roots_m[a] - filament_roots_m[b])
                if gap > 2.0 * filament_reach_m:
                    for ba in filament_bodies[a]:
                        for bb in filament_bodies[b]:
                            spec.add_exclude(bodyname1=ba, bodyname2=bb)
    opt = spec.option
    opt.cone = (
        mujoco.mjtCone.mjCONE_ELLIPTIC
        if effects.cone == "elliptic"
        else mujoco.mjtCone.mjCONE_PYRAMIDAL
    )
    opt.disableflags |= _unused_stages(spec, effects)
    if effects.aquatic:
        opt.density = effects.medium_density_kg_m3
        opt.viscosity = effects.medium_viscosity_pa_s
        _add_buoyancy(spec, effects, geom_group, body_volumes_m3 or {})
    else:
        opt.density, opt.viscosity = 0.0, 0.0


def _unused_stages(spec: mujoco.MjSpec, effects: Effects) -> int:
    """Disable-flag bits for every engine stage the effects and the assembled elements never use."""
    flags = mujoco.mjtDisableBit
    bits = flags.mjDSBL_AUTORESET  # an invalid state must reach the watchdog, not be silently reset
    limited = any(
        j.limited == mujoco.mjtLimited.mjLIMITED_TRUE
        or (j.limited == mujoco.mjtLimited.mjLIMITED_AUTO and j.range[0] < j.range[1])
        for j in spec.joints
    )
    frictionloss = any(j.frictionloss > 0 for j in spec.joints)
    equality = len(spec.equalities) > 0
    if not limited:
        bits |= flags.mjDSBL_LIMIT
    if not frictionloss:
        bits |= flags.mjDSBL_FRICTIONLOSS
    if not equality:
        bits |= flags.mjDSBL_EQUALITY
    if not spec.actuators:
        bits |= flags.mjDSBL_ACTUATION
    if not effects.gravity:
        bits |= flags.mjDSBL_GRAVITY
    if not effects.any_contact:
        bits |= flags.mjDSBL_CONTACT
        if not (limited or frictionloss or equality):
            bits |= flags.mjDSBL_CONSTRAINT
    if not effects.joint_damping:
        bits |= flags.mjDSBL_DAMPER
    return int(bits)


def _add_buoyancy(
    spec: mujoco.MjSpec, effects: Effects, geom_group: dict[str, int], volumes: Mapping[str, float]
) -> None:
    """Ellipsoid fluid model on every colliding body geom, buoyancy as gravity compensation."""
    for body in spec.bodies:
        geoms = [g for g in body.geoms if geom_group.get(g.name) in (OBJECT, FILAMENT)]
        if not geoms:
            continue
        for geom in geoms:
            geom.fluid_ellipsoid = 1.0
        if body.mass <= 0.0:
            continue
        if body.name in volumes:
            volume = volumes[body.name]
        else:
            volume = sum(_geom_volume_m3(spec, g, geom_group[g.name] == FILAMENT) for g in geoms)
        body.gravcomp = effects.medium_density_kg_m3 * volume / body.mass


def _segment_length(geom: mujoco.MjsGeom) -> float:
    """Cylinder length of a capsule or cylinder geom given by fromto or half-length, m."""
    if np.isnan(geom.fromto[0]):
        return 2.0 * float(geom.size[1])
    return float(np.linalg.norm(np.asarray(geom.fromto[3:]) - np.asarray(geom.fromto[:3])))


def _geom_volume_m3(spec: mujoco.MjSpec, geom: mujoco.MjsGeom, chain_segment: bool) -> float:
    """Volume enclosed by one geom, m^3; a chain segment counts its cylinder only (caps overlap)."""
    t, size = mujoco.mjtGeom, np.asarray(geom.size, dtype=float)
    if geom.type == t.mjGEOM_SPHERE:
        return 4.0 / 3.0 * math.pi * size[0] ** 3
    if geom.type in (t.mjGEOM_CAPSULE, t.mjGEOM_CYLINDER):
        cylinder = math.pi * size[0] ** 2 * _segment_length(geom)
        cap = (
            0.0
            if chain_segment or geom.type == t.mjGEOM_CYLINDER
            else 4.0 / 3.0 * math.pi * size[0] ** 3
        )
        return cylinder + cap
    if geom.type == t.mjGEOM_BOX:
        return 8.0 * float(np.prod(size))
    if geom.type == t.mjGEOM_ELLIPSOID:
        return 4.0 / 3.0 * math.pi * float(np.prod(size))
    if geom.type == t.mjGEOM_MESH:
        mesh = spec.mesh(geom.meshname)
        vertices = np.asarray(mesh.uservert, dtype=float).reshape(-1, 3) * np.asarray(mesh.scale)
        return float(ConvexHull(vertices).volume)
    raise TypeError(f"no volume for geom {geom.name!r} of type {geom.type}")


def _add_filament_pair(spec: mujoco.MjSpec, name1: str, name2: str, condim: int) -> None:
    """Explicit contact pair with the material of its first geom (friction, solref, solimp, margin).

    An explicit pair does not inherit geom parameters in MuJoCo, so they are copied here: set the
    geoms' material before calling `apply_effects`.
    """
    geom = spec.geom(name1)
    sliding, torsional, rolling = geom.friction
    spec.add_pair(
        geomname1=name1,
        geomname2=name2,
        condim=condim,
        friction=(sliding, sliding, torsional, rolling, rolling),
        solref=geom.solref,
        solimp=geom.solimp,
        margin=geom.margin,
        gap=geom.gap,
    )


def _geom_of(body: str) -> str:
    """Capsule geom name of a filament segment body (`fII_bJJJ` -> `fII_gJJJ`)."""
    return body.replace("_b", "_g", 1)


def collision_pairs(model: mujoco.MjModel) -> list[tuple[int, int]]:
    """Every geom pair the compiled model can ever test for contact.

    Mirrors MuJoCo's collision driver (engine_collision_driver.c): no pairs when contact or the
    constraint stage is disabled; a dynamic pair needs compatible contype/conaffinity, bodies in
    different weld groups, no parent-child relation between the weld groups (unless the parent
    filter is off, and never with the world) and no body exclude, whose signature is (min(body1,
    body2) << 16) + max(body1, body2) on the geoms' own bodies. Explicit pairs are always tested.
    """
    disabled = model.opt.disableflags
    if disabled & (mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT):
        return []
    ids = np.flatnonzero((model.geom_contype != 0) | (model.geom_conaffinity != 0))
    i, j = np.triu_indices(len(ids), k=1)
    g1, g2 = ids[i], ids[j]
    ct, ca = model.geom_contype, model.geom_conaffinity
    b1, b2 = model.geom_bodyid[g1], model.geom_bodyid[g2]
    weld, parent = model.body_weldid, model.body_parentid
    w1, w2 = weld[b1], weld[b2]
    keep = (w1 != w2) & (((ct[g1] & ca[g2]) != 0) | ((ct[g2] & ca[g1]) != 0))
    if not disabled & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        related = (weld[parent[w1]] == w2) | (weld[parent[w2]] == w1)
        keep &= ~((w1 != 0) & (w2 != 0) & related)
    signature = (np.minimum(b1, b2).astype(np.int64) << 16) + np.maximum(b1, b2)
    keep &= ~np.isin(signature, model.exclude_signature[: model.nexclude])
    out = {(int(a), int(b)) for a, b in zip(g1[keep], g2[keep])}
    for p in range(model.npair):
        g1, g2 = int(model.pair_geom1[p]), int(model.pair_geom2[p])
        out.add((min(g1, g2), max(g1, g2)))
    return sorted(out)


def pair_kinds(model: mujoco.MjModel, pairs: list[tuple[int, int]] | None = None) -> dict[str, int]:
    """Number of collision pairs of each kind (every kind of `geoms.KINDS`, zeros included)."""
    pairs = collision_pairs(model) if pairs is None else pairs
    return GeomClasses.from_model(model).count_kinds(np.asarray(pairs, dtype=np.int64).reshape(-1, 2))


def disabled_stages(model: mujoco.MjModel) -> list[str]:
    """Names of the engine stages switched off in a compiled model (e.g. 'gravity', 'contact')."""
    return [
        name.removeprefix("mjDSBL_").lower()
        for name, bit in mujoco.mjtDisableBit.__members__.items()
        if name != "mjNDISABLE" and model.opt.disableflags & int(bit)
    ]
