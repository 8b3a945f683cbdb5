"""Declared effects: the compiled model holds only those, checked against the engine itself."""

import dataclasses
import itertools
import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from entangle_bench import effects as fx
from entangle_bench.filament import FilamentParams
from entangle_bench.geoms import GeomClasses
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import get_preset
from entangle_bench.rods.case import load_case
from entangle_bench.rods.mujoco_engine import build_rod
from entangle_bench.scene import SceneConfig, build_scene

N_SEG, N_FIL = 6, 3
SMALL_GRIPPER = GripperParams(
    filament=FilamentParams(n_segments=N_SEG), ring_diameters_m=(0.05,), ring_counts=(N_FIL,)
)
TREE_GEOMS = 10  # base, trunk, 8 branches


def small_scene(
    effects: fx.Effects, gripper: GripperParams = SMALL_GRIPPER, obj="eight_branch_tree"
):
    return build_scene(
        SceneConfig(gripper=gripper, object_name=obj, effects=effects), hub_pos=(0, 0, 0.2)
    )


def engine_pairs(model: mujoco.MjModel) -> set[tuple[int, int]]:
    """Geom pairs MuJoCo itself tests: with a 10 m margin every candidate pair yields a contact.

    The midphase (a bounding-volume culling built with the compile-time margins) is switched off; it
    only drops distant pairs, never changes which pairs are candidates.
    """
    model = model.__copy__()
    model.geom_margin[:] = 10.0
    model.pair_margin[:] = 10.0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_MIDPHASE
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.warning[mujoco.mjtWarning.mjWARN_CONTACTFULL].number == 0
    return {tuple(sorted(int(g) for g in c.geom)) for c in data.contact}


@pytest.mark.parametrize("flags", list(itertools.product([False, True], repeat=4)))
def test_collision_pairs_are_exactly_those_the_engine_tests_and_the_effects_allow(flags):
    """Every contact-effect combination: the engine's pair set; per-kind counts combinatorial."""
    ff, self_, fo, ground = flags
    effects = fx.Effects(
        filament_filament_contact=ff,
        filament_self_contact=self_,
        filament_object_contact=fo,
        ground_contact=ground,
    )
    model = small_scene(effects).model
    pairs = fx.collision_pairs(model)
    assert set(pairs) == engine_pairs(model)
    expected = {
        "filament-self": self_
        * N_FIL
        * (N_SEG - 1)
        * (N_SEG - 2)
        // 2,  # non-adjacent segment pairs
        "filament-filament": ff * math.comb(N_FIL, 2) * N_SEG**2,
        "filament-object": fo * N_FIL * N_SEG * TREE_GEOMS,
        "filament-ground": ground * N_FIL * N_SEG,
        "object-ground": ground * TREE_GEOMS,
        "other": 0,
    }
    assert fx.pair_kinds(model, pairs) == expected
    hub = model.geom("hub_disk").id
    assert model.geom_contype[hub] == model.geom_conaffinity[hub] == 0
    assert all(hub not in p for p in pairs)
    contact_off = bool(model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
    assert contact_off == (not any(flags))


def test_filaments_that_can_never_touch_are_excluded():
    """Roots farther apart than two reaches: no pair between them, near neighbours still pair."""
    fil = FilamentParams(length_m=0.04, n_segments=4)
    # Two filaments 10 mm apart and one 0.3 m away (beyond 2 * (40 mm + r)).
    gripper = GripperParams(
        filament=fil, ring_diameters_m=(0.01, 0.6), ring_counts=(2, 1), hub_radius_m=0.31
    )
    model = small_scene(fx.Effects(), gripper, obj=None).model
    pairs = fx.collision_pairs(model)
    assert set(pairs) == engine_pairs(model)
    index = GeomClasses.from_model(model).filament
    cross = {
        tuple(sorted((index[a], index[b])))
        for a, b in pairs
        if min(index[a], index[b]) >= 0 and index[a] != index[b]
    }
    assert cross == {(0, 1)}
    assert model.nexclude == 2 * 4 * 4


def test_exclude_signature_uses_the_geoms_own_bodies():
    """A body welded to its parent (no joint) keeps its own id in exclude signatures."""
    spec = mujoco.MjSpec()
    for name, x in (("a", 0.0), ("c", 0.5)):
        body = spec.worldbody.add_body(name=name, pos=(x, 0, 1))
        body.add_freejoint()
        body.add_geom(name=f"{name}_geom", size=(0.05, 0, 0))
    welded = spec.body("a").add_body(name="b", pos=(0.2, 0, 0))
    welded.add_geom(name="b_geom", size=(0.05, 0, 0))
    spec.add_exclude(bodyname1="b", bodyname2="c")
    model = spec.compile()
    assert model.body_weldid[model.body("b").id] == model.body("a").id
    pairs = fx.collision_pairs(model)
    assert set(pairs) == engine_pairs(model)
    names = {tuple(sorted((model.geom(a).name, model.geom(b).name))) for a, b in pairs}
    assert names == {("a_geom", "c_geom")}


def test_rod_case_with_nothing_to_touch_compiles_without_collision():
    case = load_case(Path(__file__).parents[1] / "tasks" / "rod_cases" / "stiff_cantilever.json")
    model, _, _ = build_rod(case, 8, get_preset("balanced").numerics)
    bits = mujoco.mjtDisableBit
    assert model.opt.disableflags & bits.mjDSBL_CONTACT
    assert model.opt.disableflags & bits.mjDSBL_CONSTRAINT
    assert fx.collision_pairs(model) == []
    assert not np.any(model.geom_contype) and not np.any(model.geom_conaffinity)


def test_engine_stages_follow_the_declared_effects():
    bits = mujoco.mjtDisableBit
    default = small_scene(fx.Effects()).model
    assert not default.opt.disableflags & (
        bits.mjDSBL_GRAVITY | bits.mjDSBL_CONTACT | bits.mjDSBL_DAMPER
    )
    assert default.opt.density == default.opt.viscosity == 0.0 and default.ngravcomp == 0
    assert np.all(default.geom_fluid[:, 0] == 0.0)
    off = small_scene(
        fx.Effects(gravity=False, joint_damping=False, friction="none", cone="elliptic")
    ).model
    assert off.opt.disableflags & bits.mjDSBL_GRAVITY and off.opt.disableflags & bits.mjDSBL_DAMPER
    assert off.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    colliding = (off.geom_contype != 0) | (off.geom_conaffinity != 0)
    assert set(off.geom_condim[colliding]) == {1}
    rolling = small_scene(fx.Effects(friction="rolling")).model
    assert set(rolling.geom_condim[(rolling.geom_contype != 0)]) == {6}
    for name in ("equality", "frictionloss", "limit", "actuation", "autoreset"):
        assert name in fx.disabled_stages(default)


def test_aquatic_buoyancy_lifts_a_light_sphere_with_archimedes_force():
    """At rest in water: object acceleration g (rho_w V / m - 1), V the sphere's analytic volume."""
    effects = fx.Effects(aquatic=True, medium_density_kg_m3=1000.0, medium_viscosity_pa_s=1e-3)
    scene = build_scene(
        SceneConfig(gripper=SMALL_GRIPPER, object_name="sphere", effects=effects),
        hub_pos=(0, 0, 0.6),
        object_pos=(0, 0, 0.2),
    )
    model, data = scene.model, mujoco.MjData(scene.model)
    radius = scene.object_info.dims["diameter_m"] / 2
    volume = 4.0 / 3.0 * math.pi * radius**3
    mass = scene.object_info.mass_kg
    assert model.opt.density == 1000.0 and model.opt.viscosity == 1e-3
    mujoco.mj_forward(model, data)
    body = scene.object_body
    dof = model.jnt_dofadr[model.body_jntadr[body]]
    assert data.qacc[dof + 2] == pytest.approx(9.81 * (1000.0 * volume / mass - 1.0), rel=1e-6)
    data.qvel[dof + 2] = 0.5  # rising: drag opposes the motion
    mujoco.mj_forward(model, data)
    assert data.qfrc_fluid[dof + 2] < 0.0
    # A filament segment displaces its outer cylinder (the channel is sealed and gas-filled).
    fil = SMALL_GRIPPER.filament
    seg = model.body("f00_b002").id
    assert model.body_gravcomp[seg] * model.body_mass[seg] == pytest.approx(
        1000.0 * math.pi * fil.outer_radius_m**2 * fil.segment_length_m, rel=1e-9
    )
    assert model.geom_fluid[model.geom("f00_g002").id, 0] == 1.0


def test_gravity_length_in_air_and_water():
    fil = FilamentParams()
    assert fx.gravity_length_m(fil, fx.Effects()) == pytest.approx(fil.gravity_length_m)
    assert math.isinf(fx.gravity_length_m(fil, fx.Effects(gravity=False)))
    # A solid filament of the medium's own density is neutrally buoyant: no droop at any length.
    neutral = FilamentParams(
        channel_radius_ratio=0.0, channel_eccentricity=0.0, density_kg_m3=1000.0
    )
    assert math.isinf(fx.gravity_length_m(neutral, fx.Effects(aquatic=True)))
    # Solid section: l_g = (E r^2 / (4 |drho| g))^(1/3) since I / A = r^2 / 4.
    solid = dataclasses.replace(neutral, density_kg_m3=1500.0)
    expected = (solid.youngs_modulus_pa * solid.outer_radius_m**2 / (4 * 500.0 * 9.81)) ** (1 / 3)
    assert fx.gravity_length_m(solid, fx.Effects(aquatic=True)) == pytest.approx(expected, rel=1e-9)


def hanging_trajectory(effects: fx.Effects) -> np.ndarray:
    """qpos history of one filament in air, 0.6 s of a small pressure ramp (no contact occurs)."""
    gripper = GripperParams(
        filament=FilamentParams(n_segments=12),
        ring_diameters_m=(0.0,),
        ring_counts=(1,),
        bending_plane="fixed",
        pressure_pa=40e3,
    )
    config = SceneConfig(gripper=gripper, effects=effects, numerics=get_preset("fast").numerics)
    scene = build_scene(config, hub_pos=(0.0, 0.0, 0.5))
    model, data = scene.model, mujoco.MjData(scene.model)
    data.qpos[scene.gripper.joints.qpos[0, 3]] = (math.cos(0.05), math.sin(0.05), 0.0, 0.0)
    history = []
    while data.time < 0.6:
        scene.gripper.set_pressure(model, min(1.0, data.time / 0.3) * 40e3, np.zeros(1))
        mujoco.mj_step(model, data, nstep=5)
        assert data.ncon == 0
        history.append(data.qpos[: 4 * 12].copy())
    return np.array(history)


@pytest.mark.parametrize(
    "name",
    [
        "ground_contact",
        "filament_filament_contact",
        "filament_object_contact",
        "friction",
        "all contact",
    ],
)
def test_switching_off_an_unused_effect_leaves_the_trajectory_unchanged(name):
    """One filament hanging in free air, never touching anything: bit-identical trajectories."""
    on = fx.Effects()
    if name == "all contact":
        off = dataclasses.replace(fx.NO_CONTACT)
    else:
        off = fx.switched_off(on, name)
    assert np.array_equal(hanging_trajectory(on), hanging_trajectory(off))


def test_switching_off_a_used_effect_changes_the_trajectory():
    """The comparison above can fail: gravity is used, and switching it off changes the motion."""
    assert not np.allclose(
        hanging_trajectory(fx.Effects()), hanging_trajectory(fx.Effects(gravity=False))
    )


def test_explicit_self_contact_pairs_carry_the_geom_material():
    """Self-contact without filament-filament contact: explicit pairs with the geoms' material."""
    from entangle_bench.gripper import add_gripper, filament_positions

    spec = mujoco.MjSpec()
    gripper = add_gripper(spec, SMALL_GRIPPER)
    group = {}
    for handle in gripper.filaments:
        for name in handle.geom_names:
            spec.geom(name).friction = (0.7, 2e-4, 3e-5)
            spec.geom(name).solref = (0.01, 1.5)
            group[name] = fx.FILAMENT
    effects = fx.Effects(filament_filament_contact=False, ground_contact=False)
    fx.apply_effects(
        spec,
        effects,
        group,
        [list(h.body_names) for h in gripper.filaments],
        filament_positions(SMALL_GRIPPER),
        0.3,
    )
    model = spec.compile()
    assert model.npair == N_FIL * (N_SEG - 1) * (N_SEG - 2) // 2
    assert np.allclose(model.pair_friction, (0.7, 0.7, 2e-4, 3e-5, 3e-5))
    assert np.allclose(model.pair_solref, (0.01, 1.5))
    assert set(model.pair_dim) == {3}
    assert set(fx.collision_pairs(model)) == engine_pairs(model)
