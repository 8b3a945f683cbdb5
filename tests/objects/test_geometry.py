"""Parts and union mass properties against analytic answers and independent sampling."""

import math

import numpy as np
import pytest
import trimesh

from entangle_bench.errors import ParameterError
from entangle_bench.objects.geometry import (
    Box,
    Capsule,
    ConvexMesh,
    Cylinder,
    Moments,
    Sphere,
    hull_points,
    hull_volume,
    mesh_moments,
    union_moments,
)


def _convex_part() -> ConvexMesh:
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=0.02)
    mesh.apply_translation([0.03, 0.01, -0.02])
    return ConvexMesh("m", mesh.vertices)


PARTS = [
    Capsule("c", (0.01, 0.02, 0.0), (0.05, -0.01, 0.08), 0.01),
    Cylinder("y", (0.0, 0.0, 0.0), (0.02, 0.03, 0.05), 0.015),
    Sphere("s", (0.01, 0.0, 0.02), 0.03, shell_m=0.005),
    Box("b", (0.01, 0.02, 0.03), (0.01, 0.02, 0.03), (0.9, 0.1, 0.3, 0.2)),
    _convex_part(),
]


@pytest.mark.parametrize("part", PARTS, ids=lambda p: p.name)
@pytest.mark.parametrize("solid", [True, False])
def test_analytic_moments_match_sampled_moments(part, solid):
    rng = np.random.default_rng(3)
    pts = part.sample(100_000, rng, solid)
    assert part.contains(pts, solid).all()
    vol = part.volume(solid)
    mom = part.moments(solid)
    assert mom.volume == pytest.approx(vol, rel=1e-12)
    scale = np.abs(pts).max()
    # 100k samples: standard error of a mean ~ 0.3 % of the spread
    np.testing.assert_allclose(mom.first / vol, pts.mean(0), atol=0.01 * scale)
    np.testing.assert_allclose(mom.second / vol, pts.T @ pts / len(pts), atol=0.01 * scale**2)


def test_sampling_is_uniform_in_a_capsule():
    cap = Capsule("c", (0.0, 0.0, 0.0), (0.0, 0.0, 0.1), 0.01)
    pts = cap.sample(100_000, np.random.default_rng(0))
    in_cylinder = np.mean((pts[:, 2] >= 0) & (pts[:, 2] <= 0.1))
    expected = math.pi * 0.01**2 * 0.1 / cap.volume()
    assert in_cylinder == pytest.approx(expected, abs=0.01)


def test_convex_mesh_moments_match_trimesh():
    mesh = trimesh.creation.box(extents=[0.02, 0.04, 0.06])
    mesh.apply_translation([0.1, 0.0, 0.05])
    mom = mesh_moments(mesh.vertices, mesh.faces)
    assert mom.volume == pytest.approx(mesh.volume, rel=1e-12)
    np.testing.assert_allclose(mom.center, mesh.center_mass, atol=1e-12)
    np.testing.assert_allclose(mom.inertia(mesh.volume), mesh.moment_inertia, atol=1e-14)


def test_union_of_disjoint_parts_is_exact():
    a = Sphere("a", (0.0, 0.0, 0.0), 0.01)
    b = Box("b", (0.1, 0.0, 0.0), (0.01, 0.01, 0.01))
    union = union_moments([a, b])
    expected = a.moments() + b.moments()
    assert union.volume == expected.volume
    np.testing.assert_array_equal(union.second, expected.second)


def test_union_of_overlapping_spheres_matches_lens_formula():
    r, d = 0.02, 0.025
    union = union_moments([Sphere("a", (0, 0, 0), r), Sphere("b", (d, 0, 0), r)],
                          samples_per_part=40_000)
    lens = math.pi * (4 * r + d) * (2 * r - d) ** 2 / 12
    exact = 2 * 4 / 3 * math.pi * r**3 - lens
    assert union.volume == pytest.approx(exact, rel=0.005)
    assert union.center[0] == pytest.approx(d / 2, abs=1e-4)  # symmetric about the mid-plane


def test_union_of_two_overlapping_boxes_has_the_big_box_inertia():
    # two 60 mm boxes overlapping by 20 mm form one 100 mm box
    a = Box("a", (0.03, 0.0, 0.0), (0.03, 0.01, 0.01))
    b = Box("b", (0.07, 0.0, 0.0), (0.03, 0.01, 0.01))
    union = union_moments([a, b], samples_per_part=40_000)
    big = Box("big", (0.05, 0.0, 0.0), (0.05, 0.01, 0.01)).moments()
    assert union.volume == pytest.approx(big.volume, rel=0.01)
    expected = big.inertia(1.0)
    np.testing.assert_allclose(union.inertia(1.0), expected, atol=0.005 * np.abs(expected).max())


def test_moments_transform_like_a_rigid_motion():
    box = Box("b", (0.0, 0.0, 0.0), (0.01, 0.02, 0.03))
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    moved = box.moments().transformed(rot, [0.1, 0.0, 0.0], scale=2.0)
    direct = Box("b2", (0.1, 0.0, 0.0), (0.04, 0.02, 0.06)).moments()
    assert moved.volume == pytest.approx(direct.volume)
    np.testing.assert_allclose(moved.second, direct.second, atol=1e-15)


def test_hull_volume_of_primitives_is_close_to_exact():
    cap = Capsule("c", (0.0, 0.0, 0.0), (0.05, 0.0, 0.0), 0.01)
    assert hull_volume(hull_points([cap])) == pytest.approx(cap.volume(), rel=0.005)
    ball = Sphere("s", (0, 0, 0), 0.05)
    assert hull_volume(hull_points([ball])) == pytest.approx(ball.volume(), rel=1e-9)
    cyl = Cylinder("y", (0, 0, 0), (0, 0, 0.1), 0.02)
    assert hull_volume(hull_points([cyl])) == pytest.approx(cyl.volume(), rel=1e-9)


def test_bounds_and_radius_are_exact_for_a_tilted_cylinder():
    cyl = Cylinder("y", (0.0, 0.0, 0.0), (0.0, 0.03, 0.04), 0.01)  # axis (0, 0.6, 0.8)
    lo, hi = cyl.bounds()
    np.testing.assert_allclose(lo, [-0.01, -0.008, -0.006], atol=1e-12)
    np.testing.assert_allclose(hi, [0.01, 0.038, 0.046], atol=1e-12)
    # farthest rim point: top centre (0, 0.03) plus r along (0, 0.8, -0.6) -> (0, 0.038)
    assert cyl.max_radius() == pytest.approx(0.038, rel=1e-3)


def test_bad_parts_are_rejected():
    with pytest.raises(ParameterError):
        Capsule("c", (0, 0, 0), (0, 0, 0), 0.01)
    with pytest.raises(ParameterError):
        ConvexMesh("flat", np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float))
    with pytest.raises(ParameterError):
        Sphere("s", (0, 0, 0), 0.01, shell_m=0.02)


def test_zero_moments_are_neutral():
    box = Box("b", (0.0, 0.0, 0.0), (0.01, 0.02, 0.03)).moments()
    total = box + Moments.zero()
    assert total.volume == box.volume
