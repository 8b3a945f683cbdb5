"""Closed-form and boundary-value references for single rods, checked against each other."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson
from scipy.linalg import expm

from entangle_bench.errors import ParameterError
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import RodCase, centerline_error, load_case
from entangle_bench.rods.references import has_reference

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"


def _rod(**changes) -> RodCase:
    """A 0.3 m filament hanging along -z from (0, 0, 0.5), d1 = +x, zero gravity."""
    base = RodCase(
        name="probe",
        length=0.3,
        radius=7e-4,
        youngs_modulus=1e6,
        poisson_ratio=0.5,
        density=1100.0,
        gravity=(0.0, 0.0, 0.0),
        base_position=(0.0, 0.0, 0.5),
        base_direction=(0.0, 0.0, -1.0),
        base_normal=(1.0, 0.0, 0.0),
    )
    return dataclasses.replace(base, **changes)


def _arclength(points: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def _turning_angle(points: np.ndarray) -> np.ndarray:
    """Discrete curvature (1/m) at interior points from three-point circles."""
    a, b, c = points[:-2], points[1:-1], points[2:]
    ab, bc, ca = b - a, c - b, a - c
    area2 = np.linalg.norm(np.cross(ab, bc), axis=1)
    return (
        2.0
        * area2
        / (np.linalg.norm(ab, axis=1) * np.linalg.norm(bc, axis=1) * np.linalg.norm(ca, axis=1))
    )


@pytest.mark.parametrize(
    ("curvature", "bend_toward"),
    [((0.0, 10.0), (1.0, 0.0, 0.0)), ((10.0, 0.0), (0.0, 1.0, 0.0))],
)
def test_arc_is_a_circle_bending_the_documented_way(curvature, bend_toward):
    # d1 = +x and d2 = t x d1 = -y: k2 > 0 bends toward +d1 = +x, k1 > 0 toward -d2 = +y.
    case = _rod(intrinsic_curvature=curvature)
    points = an.rest_centerline(case, 2001)
    base = np.array(case.base_position)
    center = base + 0.1 * np.array(bend_toward)
    np.testing.assert_allclose(np.linalg.norm(points - center, axis=1), 0.1, rtol=1e-12)
    assert _arclength(points) == pytest.approx(0.3, rel=1e-6)
    angle = 3.0  # L k
    tip = center + 0.1 * (
        np.sin(angle) * np.array([0, 0, -1.0]) - np.cos(angle) * np.array(bend_toward)
    )
    np.testing.assert_allclose(points[-1], tip, atol=1e-15)


def test_closed_form_frames_match_expm_and_quadrature():
    case = _rod(intrinsic_curvature=(12.0, 16.0), intrinsic_twist=15.0)
    s = np.linspace(-0.01, case.length, 3001)
    positions, frames = an.rest_pose(case, s)
    generator = an.skew(case.darboux)
    for k in (0, 1234, 3000):
        np.testing.assert_allclose(frames[k], case.base_frame @ expm(s[k] * generator), atol=1e-13)
    numeric = cumulative_simpson(frames[:, :, 0], x=s, axis=0, initial=0.0) + positions[0]
    assert np.max(np.linalg.norm(numeric - positions, axis=1)) < 1e-9 * case.length
    fine = an.rest_pose(case, np.linspace(0.0, case.length, 4001))[0]
    assert _arclength(fine) == pytest.approx(case.length, rel=1e-6)


def test_helix_radius_pitch_and_reduction_to_circle():
    case = _rod(intrinsic_curvature=(12.0, 16.0), intrinsic_twist=15.0)
    radius, pitch = an.helix_geometry(case)
    assert (radius, pitch) == pytest.approx((20 / 625, 2 * np.pi * 15 / 625), rel=1e-12)
    points = an.rest_centerline(case, 4001)
    # The world Darboux vector R Omega is constant: it is the helix axis. The principal normal
    # t' / |t'| at the base points at the axis, which lies one radius away.
    axis = case.base_frame @ case.darboux / np.linalg.norm(case.darboux)
    t0 = case.base_frame[:, 0]
    normal = np.cross(axis, t0) / np.linalg.norm(np.cross(axis, t0))
    axis_point = np.asarray(case.base_position) + radius * normal
    distance = np.linalg.norm(np.cross(points - axis_point, axis), axis=1)
    np.testing.assert_allclose(distance, radius, rtol=1e-12)
    # One full turn of arclength 2 pi sqrt(R^2 + c^2) advances by one pitch along the axis.
    turn = 2 * np.pi * np.hypot(radius, pitch / (2 * np.pi))
    ds = case.length / 4000
    k = round(turn / ds)
    advance = (points[k] - points[0]) @ axis
    assert advance == pytest.approx(pitch * k * ds / turn, rel=1e-9)
    # Zero twist: the helix degenerates to the circle of radius 1/kappa in one plane.
    flat = _rod(intrinsic_curvature=(12.0, 16.0))
    assert an.helix_geometry(flat) == pytest.approx((1 / 20, 0.0))
    flat_points = an.rest_centerline(flat, 501)
    assert np.max(np.abs((flat_points - flat_points[0]) @ (flat.base_frame @ flat.darboux))) < 1e-15
    np.testing.assert_allclose(_turning_angle(flat_points), 20.0, rtol=1e-5)


def test_small_deflection_formula_values():
    case = load_case(CASE_DIR / "stiff_cantilever.json")
    q = case.density * np.pi * case.radius**2 * 9.81
    ei = case.youngs_modulus * np.pi * case.radius**4 / 4
    assert an.small_deflection_tip(case) == pytest.approx(q * case.length**4 / (8 * ei), rel=1e-12)
    line = an.small_deflection_centerline(case, 3)
    mid = q * (case.length / 2) ** 2 * (6 - 2 + 0.25) * case.length**2 / (24 * ei)
    assert case.base_position[2] - line[1, 2] == pytest.approx(mid, rel=1e-12)
    with pytest.raises(ParameterError, match="zero intrinsic curvature"):
        an.small_deflection_centerline(_rod(intrinsic_curvature=(0.0, 1.0)))


def test_elastica_matches_small_deflection_for_stiff_rod():
    case = load_case(CASE_DIR / "stiff_cantilever.json")
    tip = an.small_deflection_tip(case)
    assert tip < 0.02 * case.length
    nonlinear = an.planar_elastica_centerline(case, 201)
    linear = an.small_deflection_centerline(case, 201)
    drop = case.base_position[2] - nonlinear[:, 2]
    assert drop[-1] == pytest.approx(tip, rel=0.01)  # measured: 0.67 % below the linear tip
    assert np.max(np.abs(drop - (case.base_position[2] - linear[:, 2]))) < 0.01 * tip
    assert centerline_error(nonlinear, linear, case.length)[0] < 0.01 * tip / case.length


@pytest.mark.parametrize("name", ["soft_cantilever", "curl_hanging", "stiff_cantilever"])
def test_planar_elastica_agrees_with_3d_kirchhoff_bvp(name):
    case = load_case(CASE_DIR / f"{name}.json")
    planar = an.planar_elastica_centerline(case, 4001)
    spatial = an.kirchhoff_centerline(case, 4001)
    assert centerline_error(planar, spatial, case.length)[0] < 1e-8  # measured ~1e-11
    assert _arclength(planar) == pytest.approx(case.length, rel=1e-6)


def test_soft_cantilever_is_large_deflection_and_in_equilibrium():
    case = load_case(CASE_DIR / "soft_cantilever.json")
    points = an.planar_elastica_centerline(case, 4001)
    drop = (case.base_position[2] - points[-1, 2]) / case.length
    assert 0.2 < drop < 0.6
    assert an.small_deflection_tip(case) / case.length > drop + 0.05  # linear theory: 0.47 L
    # Independent check of moment balance: E I times the curvature of the computed shape equals
    # the moment of the weight beyond s, |int_s^L (x(s') - x(s)) x rho A g ds'|.
    s = np.linspace(0.0, case.length, points.shape[0])
    weight = case.line_density * np.asarray(case.gravity)
    idx = np.arange(200, 3800, 400)
    for i in idx:
        arm = points[i:] - points[i]
        moment = np.linalg.norm(np.trapezoid(np.cross(arm, weight), s[i:], axis=0))
        curvature = _turning_angle(points[i - 1 : i + 2])[0]
        # measured 2e-4: the curvature of solve_bvp's cubic interpolant is second-order accurate
        assert case.bending_stiffness * curvature == pytest.approx(moment, rel=1e-3)


def test_kirchhoff_bvp_from_straight_reproduces_closed_form_helix():
    case = load_case(CASE_DIR / "helix_zero_gravity.json")
    closed = an.rest_centerline(case)
    bvp = an.kirchhoff_centerline(case)
    assert centerline_error(closed, bvp, case.length)[0] < 1e-8  # measured ~5e-13


def test_sideways_curl_is_three_dimensional():
    case = load_case(CASE_DIR / "curl_sideways_gravity.json")
    assert an.planar_plane(case) is None
    with pytest.raises(ParameterError, match="not planar"):
        an.planar_elastica_centerline(case)
    points, method = an.reference_centerline(case, 4001)
    assert method == "kirchhoff_bvp"
    assert _arclength(points) == pytest.approx(case.length, rel=1e-6)
    extent = np.ptp(points, axis=0) / case.length
    assert np.all(extent > 0.3)  # bends in all three directions


def test_reference_method_per_case_file():
    # Cases with a stored PyElastica reference (tasks/rod_cases/references/) are tested in test_references.
    methods = {
        path.stem: an.reference_centerline(load_case(path), 21)[1]
        for path in sorted(CASE_DIR.glob("*.json"))
        if not has_reference(load_case(path))
    }
    assert methods == {
        "arc_zero_gravity": "rest_shape",
        "coil_zero_gravity": "rest_shape",
        "curl_hanging": "planar_elastica",
        "curl_sideways_gravity": "kirchhoff_bvp",
        "helix_zero_gravity": "rest_shape",
        "soft_cantilever": "planar_elastica",
        "stiff_cantilever": "planar_elastica",
    }
    coil = load_case(CASE_DIR / "coil_zero_gravity.json")
    assert an.helix_geometry(coil) == pytest.approx((0.020, 0.006), rel=1e-6)
