"""Object registry: names, params, ObjectInfo, phi_T and the MuJoCo body that add_object builds."""

import dataclasses
import itertools
import math

import mujoco
import numpy as np
import pytest

from entangle_bench import objects
from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.objects import primitives, trees
from entangle_bench.objects.geometry import Box, union_moments

REQUIRED = {
    "eight_branch_tree", "random_tree", "sphere", "tennis_ball", "cylinder_38", "cylinder_51",
    "cylinder_51_hollow", "cube", "bracket",
}


def test_names_cover_the_library():
    names = objects.names()
    assert REQUIRED <= set(names)
    assert len([n for n in names if n.startswith("dexnet_")]) >= 4
    assert names == sorted(names)


def test_unknown_name_lists_the_known_ones():
    with pytest.raises(UnknownNameError) as err:
        objects.object_info("teapot")
    assert "teapot" in str(err.value) and "eight_branch_tree" in str(err.value)
    assert err.value.known == objects.names()
    with pytest.raises(UnknownNameError):
        objects.default_params("teapot")


def test_params_are_frozen_and_validated():
    p = objects.default_params("eight_branch_tree")
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.mass_kg = 1.0
    with pytest.raises(ParameterError, match="branch_length_m"):
        dataclasses.replace(p, branch_length_m=-0.01)
    with pytest.raises(ParameterError, match="mass_kg"):
        dataclasses.replace(objects.default_params("sphere"), mass_kg=0.0)
    with pytest.raises(ParameterError, match="must be SphereParams"):
        objects.object_info("sphere", primitives.CubeParams())


def test_reference_tree_is_plausible():
    p = objects.default_params("eight_branch_tree")
    assert 0.10 <= p.trunk_height_m <= 0.15 and p.branch_count == 8
    assert 0.04 <= p.branch_length_m <= 0.06 and 0.02 <= p.mass_kg <= 0.05
    info = objects.object_info("eight_branch_tree")
    assert info.n_parts == 10  # base, trunk, 8 branches
    assert 0.0 < info.phi_t < 0.2


def test_primitive_sizes_and_masses():
    for name, diameter, mass in [("sphere", 0.100, None), ("tennis_ball", 0.067, 0.058),
                                 ("cylinder_38", 0.038, None), ("cylinder_51", 0.051, None)]:
        info = objects.object_info(name)
        assert 2 * info.radius_m == pytest.approx(diameter, rel=1e-3)
        if mass is not None:
            assert info.mass_kg == pytest.approx(mass)
    assert objects.object_info("sphere").height_m == pytest.approx(0.1)


def test_phi_t_of_convex_objects_is_one():
    for name in ("cube", "sphere", "cylinder_38"):
        assert objects.object_info(name).phi_t == pytest.approx(1.0, abs=2e-3)


def test_tube_volume_is_the_polygon_annulus():
    p = objects.default_params("cylinder_51_hollow")
    info = objects.object_info("cylinder_51_hollow")
    n, r_out = p.wall_segments, p.diameter_m / 2
    r_in = r_out - p.wall_thickness_m
    exact = n * math.tan(math.pi / n) * (r_out**2 - r_in**2) * p.height_m
    assert info.volume_m3 == pytest.approx(exact, rel=0.01)
    assert info.phi_t < 0.3  # open tube: mostly empty hull


def _tree_phi(**changes):
    p = dataclasses.replace(trees.EightBranchTreeParams(), **changes)
    return objects.object_info("eight_branch_tree", p).phi_t


def test_phi_t_falls_with_branch_length_and_rises_with_branch_count():
    # phi_T = V / V_hull: V grows linearly with branch length, the hull about quadratically
    by_length = [_tree_phi(branch_length_m=x) for x in (0.01, 0.03, 0.06)]
    assert all(a > b for a, b in itertools.pairwise(by_length))
    # more branches of the same length add volume but, once they ring the trunk, little hull
    by_count = [_tree_phi(branch_count=n) for n in (8, 16, 24)]
    assert all(a < b for a, b in itertools.pairwise(by_count))


def test_tree_volume_and_centroid_match_plain_monte_carlo():
    # independent estimate: uniform points in the bounding box, inside if in any part
    built = objects.build("eight_branch_tree")
    lo = np.min([p.bounds()[0] for p in built.parts], axis=0)
    hi = np.max([p.bounds()[1] for p in built.parts], axis=0)
    rng = np.random.default_rng(7)
    n_total, hits, first = 0, 0, np.zeros(3)
    for _ in range(5):
        pts = rng.uniform(lo, hi, size=(200_000, 3))
        inside = np.zeros(len(pts), bool)
        for part in built.parts:
            inside |= part.contains(pts)
        n_total += len(pts)
        hits += int(inside.sum())
        first += pts[inside].sum(0)
    volume = np.prod(hi - lo) * hits / n_total
    # ~26k hits: 0.6 % volume and 0.25 mm centroid standard errors
    assert built.info.volume_m3 == pytest.approx(volume, rel=0.03)
    np.testing.assert_allclose(built.center_of_mass, first / hits, atol=1e-3)


def test_mass_scales_as_requested():
    base = objects.default_params("eight_branch_tree")
    one = objects.build("eight_branch_tree", base)
    three = objects.build("eight_branch_tree", dataclasses.replace(base, mass_kg=3 * base.mass_kg))
    assert three.info.mass_kg == pytest.approx(3 * base.mass_kg)
    np.testing.assert_allclose(three.inertia, 3 * one.inertia, rtol=1e-12)
    spec = mujoco.MjSpec()
    objects.add_object(spec, "eight_branch_tree", dataclasses.replace(base, mass_kg=0.05))
    model = spec.compile()
    assert model.body("object").mass[0] == pytest.approx(0.05)


def test_inertia_of_primitives_is_analytic():
    cube = objects.build("cube")
    a, m = 0.05, 0.075
    np.testing.assert_allclose(cube.inertia, m * a * a / 6 * np.eye(3), atol=1e-12)
    ball = objects.build("tennis_ball")
    r_o, r_i, m = 0.0335, 0.0335 - 0.006, 0.058
    shell = 0.4 * m * (r_o**5 - r_i**5) / (r_o**3 - r_i**3)
    np.testing.assert_allclose(ball.inertia, shell * np.eye(3), rtol=1e-9, atol=1e-15)
    cyl = objects.build("cylinder_38")
    r, h, m = 0.019, 0.1, 0.05
    np.testing.assert_allclose(np.diag(cyl.inertia),
                               [m * (3 * r * r + h * h) / 12] * 2 + [m * r * r / 2], rtol=1e-9)


def _compiled(name, params=None, pos=(0.0, 0.0, 0.0)):
    spec = mujoco.MjSpec()
    info = objects.add_object(spec, name, params, pos=pos)
    model = spec.compile()
    return info, model


@pytest.mark.parametrize("name", ["eight_branch_tree", "bracket", "cylinder_51_hollow",
                                  "dexnet_endstop_holder"])
def test_add_object_builds_one_free_body_with_object_geoms(name):
    info, model = _compiled(name)
    body = model.body("object")
    assert model.njnt == 1 and model.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert model.jnt_bodyid[0] == body.id
    geoms = [i for i in range(model.ngeom) if model.geom_bodyid[i] == body.id]
    names = tuple(model.geom(i).name for i in geoms)
    assert names == info.geom_names and len(names) == info.n_parts
    assert all(n.startswith("object_") for n in names)
    assert all(model.geom_contype[i] == 1 and model.geom_conaffinity[i] == 1
               and model.geom_condim[i] == 3 for i in geoms)
    assert body.mass[0] == pytest.approx(info.mass_kg)
    # explicit inertia: MuJoCo diagonalises our tensor; eigenvalues must agree
    eig = np.sort(np.linalg.eigvalsh(np.array(info.inertia_kg_m2)))
    np.testing.assert_allclose(np.sort(body.inertia), eig, rtol=1e-6)


def test_origin_is_on_the_axis_at_the_lowest_point():
    # lowest and highest geom points of the compiled model, via MuJoCo's own geom frames
    for name in ("eight_branch_tree", "sphere", "bracket", "cube"):
        info, model = _compiled(name, pos=(0.2, -0.1, 0.0))
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        lows, highs = [], []
        for g in range(model.ngeom):
            size, gtype = model.geom_size[g], model.geom_type[g]
            c, rot = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3)
            axis = rot[:, 2]
            if gtype == mujoco.mjtGeom.mjGEOM_BOX:
                ext = np.abs(rot) @ size
            elif gtype == mujoco.mjtGeom.mjGEOM_SPHERE:
                ext = np.full(3, size[0])
            elif gtype == mujoco.mjtGeom.mjGEOM_CAPSULE:
                ext = np.abs(axis) * size[1] + size[0]
            else:
                assert gtype == mujoco.mjtGeom.mjGEOM_CYLINDER
                ext = np.abs(axis) * size[1] + size[0] * np.sqrt(np.clip(1 - axis**2, 0, None))
            lows.append(c - ext)
            highs.append(c + ext)
        lo, hi = np.min(lows, axis=0), np.max(highs, axis=0)
        assert lo[2] == pytest.approx(0.0, abs=1e-9), name
        assert hi[2] == pytest.approx(info.height_m, abs=1e-9), name
        if name != "eight_branch_tree":  # trees: trunk axis, not box centre
            np.testing.assert_allclose((lo[:2] + hi[:2]) / 2, [0.2, -0.1], atol=1e-9)


def test_a_second_object_is_refused():
    spec = mujoco.MjSpec()
    objects.add_object(spec, "cube")
    with pytest.raises(ParameterError, match="already has a body"):
        objects.add_object(spec, "sphere")


def test_random_tree_is_seeded():
    a = objects.object_info("random_tree", trees.RandomTreeParams(seed=1))
    b = objects.object_info("random_tree", trees.RandomTreeParams(seed=1))
    c = objects.object_info("random_tree", trees.RandomTreeParams(seed=2))
    assert a == b
    assert a.volume_m3 != c.volume_m3


def test_bracket_volume_is_sum_of_parts_minus_overlaps():
    p = objects.default_params("bracket")
    info = objects.object_info("bracket")
    bar = p.bar_length_m * p.bar_width_m * p.thickness_m
    jaws = 2 * p.jaw_width_m * p.jaw_length_m * p.thickness_m  # beyond the bar
    handle = math.pi * p.handle_radius_m**2 * p.handle_length_m
    assert info.volume_m3 == pytest.approx(bar + jaws + handle, rel=1e-3)
    # and the Monte Carlo overlap removal agrees with that exact value for the boxes alone
    boxes = [Box("a", (0, 0, 0), (0.05, 0.01, 0.01)),
             Box("b", (0.04, 0.0, 0.0), (0.01, 0.03, 0.01))]
    assert union_moments(boxes).volume == pytest.approx(
        0.1 * 0.02 * 0.02 + 0.02 * 0.04 * 0.02, rel=0.01)
