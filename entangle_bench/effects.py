"""Physical effects a scene declares; the compiled model contains only those.

Collision groups use MuJoCo's contype/conaffinity bit masks: each geom's contype is its own group bit and its
conaffinity is the set of groups it may touch, so two geoms collide only if the declared effects allow the pair
(MuJoCo collides a pair when contype1 & conaffinity2 or contype2 & conaffinity1 is non-zero). Finer rules
(self-contact, filaments that can never reach each other) become explicit body excludes or explicit pairs.
Engine stages nobody needs are switched off with disable flags, and the fluid model is compiled in only for
aquatic scenes.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, fields
from typing import Literal

import mujoco
import numpy as np

from entangle_bench.config import check_choice, check_range

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
    """Immerse the scene in a fluid (MuJoCo ellipsoid fluid model: buoyancy, added mass, drag)."""
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


def apply_effects(
    spec: mujoco.MjSpec,
    effects: Effects,
    geom_group: dict[str, int],
    filament_bodies: list[list[str]],
    filament_roots_m: np.ndarray,
    filament_reach_m: float,
) -> None:
    """Set collision masks, friction model, excludes, disable flags and fluid on an assembled `spec`.

    `geom_group` maps every colliding geom name to GROUND, OBJECT or FILAMENT; other geoms never collide.
    `filament_bodies[i]` lists filament i's segment bodies root to tip; `filament_roots_m` (F, 2) the root
    positions; two filaments whose roots are more than 2 * `filament_reach_m` apart can never touch.
    """
    masks = affinity(effects)
    condim = CONDIM[effects.friction]
    for geom in spec.geoms:
        group = geom_group.get(geom.name)
        if group is None:
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
                    spec.add_pair(
                        geomname1=_geom_of(bodies[j]), geomname2=_geom_of(bodies[k]), condim=condim
                    )
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
        mujoco.mjtCone.mjCONE_ELLIPTIC if effects.cone == "elliptic" else mujoco.mjtCone.mjCONE_PYRAMIDAL
    )
    flags = mujoco.mjtDisableBit
    opt.disableflags |= flags.mjDSBL_FRICTIONLOSS | flags.mjDSBL_LIMIT | flags.mjDSBL_AUTORESET
    if not effects.gravity:
        opt.disableflags |= flags.mjDSBL_GRAVITY
    if not effects.any_contact:
        opt.disableflags |= flags.mjDSBL_CONTACT
    if not effects.joint_damping:
        opt.disableflags |= flags.mjDSBL_DAMPER
    if effects.aquatic:
        opt.density = effects.medium_density_kg_m3
        opt.viscosity = effects.medium_viscosity_pa_s
        for geom in spec.geoms:
            if geom.name in geom_group and geom_group[geom.name] != GROUND:
                geom.fluid_ellipsoid = 1.0
    else:
        opt.density, opt.viscosity = 0.0, 0.0


def _geom_of(body: str) -> str:
    """Capsule geom name of a filament segment body (`fII_bJJJ` -> `fII_gJJJ`)."""
    return body.replace("_b", "_g", 1)


def collision_pairs(model: mujoco.MjModel) -> list[tuple[int, int]]:
    """Every geom pair the compiled model can ever test for contact (masks, filters, excludes, pairs)."""
    body_parent = model.body_parentid
    excluded = set(int(s) for s in model.exclude_signature[: model.nexclude])
    out = set()
    if not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT:
        filter_parent = not model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT
        ids = np.flatnonzero((model.geom_contype != 0) | (model.geom_conaffinity != 0))
        ct, ca, gb = model.geom_contype, model.geom_conaffinity, model.geom_bodyid
        weld = model.body_weldid
        for n, g1 in enumerate(ids):
            for g2 in ids[n + 1 :]:
                b1, b2 = int(gb[g1]), int(gb[g2])
                if weld[b1] == weld[b2]:
                    continue
                if not (ct[g1] & ca[g2] or ct[g2] & ca[g1]):
                    continue
                w1, w2 = int(weld[b1]), int(weld[b2])
                if filter_parent and w1 != 0 and w2 != 0 and (
                    weld[body_parent[w1]] == w2 or weld[body_parent[w2]] == w1
                ):
                    continue
                if ((min(w1, w2) << 16) + max(w1, w2)) in excluded:
                    continue
                out.add((int(g1), int(g2)))
        for p in range(model.npair):
            g1, g2 = int(model.pair_geom1[p]), int(model.pair_geom2[p])
            out.add((min(g1, g2), max(g1, g2)))
    return sorted(out)
