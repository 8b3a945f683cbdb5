"""Contact classification on small MuJoCo scenes: kinds, counts and force balance."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.geoms import KINDS, GeomClasses
from entangle_bench.metrics.contacts import contact_summary, object_support

GRAVITY = 9.81
BOX_MASS, CAPSULE_MASS, RADIUS = 0.2, 0.01, 0.005


def stack_scene(apart: bool = False) -> mujoco.MjModel:
    """Box (the object) on the ground; filaments 0 and 1 lie on it along x, filament 2 crosses both
    along y on top; filament 3 lies on the ground. With `apart`, everything floats far apart."""
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    world = spec.worldbody
    world.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1])
    lift = 1.0 if apart else 0.0
    box = world.add_body(name="object", pos=[0, 0, 0.02 + lift])
    box.add_freejoint()
    box.add_geom(
        name="object_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.02], mass=BOX_MASS
    )
    placements = [
        ([0, -0.02, 0.04 + RADIUS], [1, 0, 0]),
        ([0, 0.02, 0.04 + RADIUS], [1, 0, 0]),
        ([0, 0, 0.04 + 3 * RADIUS], [0, 1, 0]),
        ([0.3, 0, RADIUS], [1, 0, 0]),
    ]
    for i, (pos, axis) in enumerate(placements):
        offset = [0, 0, lift + 0.3 * (i + 1)] if apart else [0, 0, 0]
        body = world.add_body(name=f"f{i:02d}_b000", pos=np.add(pos, offset))
        body.add_freejoint()
        half = 0.04 * np.asarray(axis, float)
        body.add_geom(
            name=f"f{i:02d}_g000",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            size=[RADIUS, 0, 0],
            fromto=np.r_[-half, half],
            mass=CAPSULE_MASS,
        )
    return spec.compile()


def test_geom_classes_parse_the_naming_conventions():
    model = stack_scene()
    geoms = GeomClasses.from_model(model)
    names = [model.geom(g).name for g in range(model.ngeom)]
    assert dict(zip(names, geoms.filament.tolist())) == {
        "ground": -1,
        "object_box": -1,
        "f00_g000": 0,
        "f01_g000": 1,
        "f02_g000": 2,
        "f03_g000": 3,
    }
    assert [n for n, o in zip(names, geoms.is_object) if o] == ["object_box"]
    assert [n for n, g in zip(names, geoms.is_ground) if g] == ["ground"]
    assert geoms.n_filaments == 4


def test_resting_stack_counts_and_force_balance():
    model = stack_scene()
    data = mujoco.MjData(model)
    for _ in range(500):  # 1 s: the stack settles
        mujoco.mj_step(model, data)
    summary = contact_summary(model, data)
    counts = summary.counts
    assert set(counts) == set(KINDS)
    assert counts["filament-filament"] == 2  # filament 2 crosses 0 and 1
    assert counts["object-ground"] == 4  # box corners
    assert counts["filament-object"] >= 2 and counts["filament-ground"] >= 1
    assert counts["filament-self"] == counts["other"] == 0
    assert len(summary.points) == len(summary.kinds) == len(summary.normal_forces_n)
    assert sum(counts.values()) == len(summary.kinds)
    per_filament = summary.per_filament.tolist()
    assert per_filament[0] + per_filament[1] == 2 + counts["filament-object"]
    assert per_filament[2:] == [2, counts["filament-ground"]]
    weight = CAPSULE_MASS * GRAVITY
    # Static equilibrium: each support carries the weight of everything above it.
    assert summary.normal_force_sum_n("filament-filament") == pytest.approx(weight, rel=0.02)
    assert summary.normal_force_sum_n("filament-object") == pytest.approx(3 * weight, rel=0.02)
    assert summary.normal_force_sum_n("filament-ground") == pytest.approx(weight, rel=0.02)
    assert summary.normal_force_sum_n("object-ground") == pytest.approx(
        BOX_MASS * GRAVITY + 3 * weight, rel=0.02
    )
    # Filament-filament contacts sit where the top capsule crosses the lower ones.
    ff = summary.points[summary.kinds == "filament-filament"]
    np.testing.assert_allclose(np.sort(ff[:, 1]), [-0.02, 0.02], atol=2e-3)
    np.testing.assert_allclose(ff[:, 2], 0.04 + 2 * RADIUS, atol=1e-3)


def test_far_apart_bodies_have_no_contacts():
    model = stack_scene(apart=True)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    summary = contact_summary(model, data, GeomClasses.from_model(model))
    assert all(v == 0 for v in summary.counts.values())
    assert summary.points.shape == (0, 3)
    assert summary.per_filament.tolist() == [0, 0, 0, 0]


def test_classify_geom_pairs_covers_every_kind():
    # geoms: 0 ground, 1 object, 2-3 filament 0, 4 filament 1, 5 other (e.g. hub)
    geoms = GeomClasses.from_names(["ground", "object_a", "f00_g000", "f00_g001", "f01_g000", "hub_disk"])
    expected = {
        (2, 1): "filament-object",
        (4, 2): "filament-filament",
        (2, 3): "filament-self",
        (0, 4): "filament-ground",
        (1, 0): "object-ground",
        (5, 2): "other",  # the hub disk touches nothing by kind
        (5, 1): "other",
    }
    pairs = list(expected)
    kinds = geoms.kinds(pairs)
    assert dict(zip(pairs, kinds.tolist())) == expected
    assert set(kinds) | {"other"} == set(KINDS)
    assert geoms.count_kinds(pairs) == {kind: kinds.tolist().count(kind) for kind in KINDS}


def test_rejects_misshapen_class_arrays():
    model = stack_scene()
    data = mujoco.MjData(model)
    geoms = GeomClasses.from_model(model)
    with pytest.raises(ParameterError, match="the model has 6"):
        contact_summary(model, data, GeomClasses.from_names(["ground", "object_box"]))
    with pytest.raises(ParameterError, match="is_object"):
        GeomClasses(geoms.filament, geoms.is_object.astype(int), geoms.is_ground)
    with pytest.raises(ParameterError, match="filament"):
        GeomClasses(geoms.filament.astype(float), geoms.is_object, geoms.is_ground)
    with pytest.raises(ParameterError, match="contact kind"):
        contact_summary(model, data, geoms).normal_force_sum_n("x")


def groove_scene() -> mujoco.MjModel:
    """A fixed object: a right-angled V-groove of two plates (`object_left`, `object_right`, vertex along y at
    the origin) and a flat shelf (`object_shelf`, top at z = 0, at x = 0.2 m). Filament 0 lies in the groove,
    touching both plates; filament 1 lies on the shelf."""
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    obj = spec.worldbody.add_body(name="object")
    half, thick, s = 0.03, 0.005, np.sqrt(0.5)
    for name, side in (("left", -1), ("right", 1)):
        along, normal = np.array([side * s, 0, s]), np.array([-side * s, 0, s])  # up the plate, into the groove
        angle = -side * np.pi / 4  # about y
        obj.add_geom(name=f"object_{name}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[half, 0.05, thick],
                     pos=half * along - thick * normal, quat=[np.cos(angle / 2), 0, np.sin(angle / 2), 0])
    obj.add_geom(name="object_shelf", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, thick],
                 pos=[0.2, 0, -thick])
    for i, pos in enumerate(([0, 0, RADIUS / s + 0.002], [0.2, 0, RADIUS + 0.002])):
        body = spec.worldbody.add_body(name=f"f{i:02d}_b000", pos=pos)
        body.add_freejoint()
        body.add_geom(name=f"f{i:02d}_g000", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[RADIUS, 0, 0],
                      fromto=[0, -0.04, 0, 0, 0.04, 0], mass=CAPSULE_MASS)
    return spec.compile()


def test_a_segment_touching_two_object_faces_is_pinched_and_statics_balance():
    model = groove_scene()
    data = mujoco.MjData(model)
    for _ in range(500):  # 1 s: both capsules come to rest
        mujoco.mj_step(model, data)
    geoms = GeomClasses.from_model(model)
    support = object_support(model, data, geoms)
    weight = np.array([0.0, 0.0, -CAPSULE_MASS * GRAVITY])
    # The grooved capsule presses on both plates: all of its weight goes to `pinched`, none to a part.
    np.testing.assert_allclose(support.pinched, weight, atol=0.02 * CAPSULE_MASS * GRAVITY)
    assert list(support.by_part) == ["shelf"]
    np.testing.assert_allclose(support.by_part["shelf"], weight, atol=0.02 * CAPSULE_MASS * GRAVITY)
    np.testing.assert_allclose(support.filament_total, 2 * weight, atol=0.04 * CAPSULE_MASS * GRAVITY)
    assert not support.ground.any() and support.filament_filament_n == 0.0
    # The wedge's normal forces exceed the weight: each plate pushes with W / (2 cos 45°) = W / √2.
    summary = contact_summary(model, data, geoms)
    grooved = summary.normal_forces_n[(summary.kinds == "filament-object") & (summary.points[:, 0] < 0.1)]
    assert grooved.sum() == pytest.approx(np.sqrt(2) * CAPSULE_MASS * GRAVITY, rel=0.03)


def raft_scene() -> mujoco.MjModel:
    """A box (the object) resting on two filaments (0, 1) that lie on the ground along x, and filament 2 lying
    on the box along y: the box touches the ground only through filaments 0 and 1."""
    spec = mujoco.MjSpec()
    spec.option.timestep = 0.002
    world = spec.worldbody
    world.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.1])
    box = world.add_body(name="object", pos=[0, 0, 2 * RADIUS + 0.02])
    box.add_freejoint()
    box.add_geom(name="object_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.02], mass=BOX_MASS)
    for i, (pos, axis) in enumerate((([0, -0.03, RADIUS], [1, 0, 0]), ([0, 0.03, RADIUS], [1, 0, 0]),
                                     ([0, 0, 2 * RADIUS + 0.04 + RADIUS], [0, 1, 0]))):
        body = world.add_body(name=f"f{i:02d}_b000", pos=pos)
        body.add_freejoint()
        half = 0.04 * np.asarray(axis, float)
        body.add_geom(name=f"f{i:02d}_g000", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[RADIUS, 0, 0],
                      fromto=np.r_[-half, half], mass=CAPSULE_MASS)
    return spec.compile()


def test_a_segment_between_the_object_and_the_ground_is_ground_pinched_and_statics_balance():
    model = raft_scene()
    data = mujoco.MjData(model)
    for _ in range(500):  # 1 s: everything comes to rest
        mujoco.mj_step(model, data)
    support = object_support(model, data, GeomClasses.from_model(model))
    g, tol = GRAVITY, 0.02 * (BOX_MASS + CAPSULE_MASS) * GRAVITY
    # The two filaments under the box carry it and the filament on it: (M + m) g upward, all ground-pinched.
    np.testing.assert_allclose(support.ground_pinched, [0.0, 0.0, (BOX_MASS + CAPSULE_MASS) * g], atol=tol)
    assert list(support.by_part) == ["box"]  # the filament on top presses down on the box
    np.testing.assert_allclose(support.by_part["box"], [0.0, 0.0, -CAPSULE_MASS * g], atol=tol)
    assert not support.ground.any() and not support.pinched.any()
    np.testing.assert_allclose(support.filament_total, [0.0, 0.0, BOX_MASS * g], atol=tol)
