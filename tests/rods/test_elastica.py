"""PyElastica reference engine against the closed-form and boundary-value references.

Tolerances are the measured errors (in the comments) with a margin of about 1.5-2; errors are
max |x - x_ref| / L over the centerline at uniform arclength.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import centerline_error, load_case
from entangle_bench.rods.elastica_engine import build_rod, discrete_rest_shape, perturbed_start, solve_elastica

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"


def _case(name: str):
    return load_case(CASE_DIR / f"{name}.json")


def test_rest_curvature_maps_to_pyelastica_darboux_vector():
    # The discrete rest shape built from the case convention must be strain-free in
    # PyElastica's own kinematics: its computed kappa equals rest_kappa = (k1, k2, tau).
    case = dataclasses.replace(
        _case("helix_zero_gravity"), intrinsic_curvature=(12.0, -16.0), intrinsic_twist=15.0
    )
    rod = build_rod(case, 30, initial="rest")
    rod.compute_internal_forces_and_torques(0.0)
    np.testing.assert_allclose(
        rod.kappa, np.array([[12.0], [-16.0], [15.0]]) * np.ones((1, 29)), rtol=1e-9
    )
    np.testing.assert_allclose(rod.sigma, 0.0, atol=1e-12)
    assert np.max(np.abs(rod.internal_torques)) < 1e-9 * case.bending_stiffness * 16.0
    positions, directors = discrete_rest_shape(case, 30)
    h = case.length / 29.5
    midpoint = 0.5 * (positions[:, 0] + positions[:, 1])
    np.testing.assert_allclose(midpoint, case.base_position, atol=1e-15)
    np.testing.assert_allclose(directors[:, :, 0], case.base_frame[:, [1, 2, 0]].T, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(np.diff(positions, axis=1), axis=0), h, rtol=1e-12)


@pytest.mark.parametrize(
    "darboux", [(0.0, 40.0, 0.0), (40.0, 0.0, 0.0), (24.0, 32.0, 30.0)], ids=["k2", "k1", "helix"]
)
def test_curling_from_straight_reaches_the_analytic_shape(darboux):
    # A 35 mm rod released straight in zero gravity must curl into the closed-form arc or helix,
    # toward +d1 for k2 > 0 and -d2 for k1 > 0 (a sign error would give an error of order L).
    case = dataclasses.replace(
        _case("soft_cantilever"),
        gravity=(0.0, 0.0, 0.0),
        intrinsic_curvature=darboux[:2],
        intrinsic_twist=darboux[2],
    )
    result = solve_elastica(case, 20, initial="straight")
    assert result.settings["converged"]
    max_err, rms_err = centerline_error(result.centerline, an.rest_centerline(case), case.length)
    assert max_err < 8e-4  # measured 5.4e-4 (the h^2 k / 8 offset of the half clamp element)
    assert rms_err < 6e-4  # measured 4.3e-4


def test_stiff_cantilever_matches_small_deflection_formula():
    case = _case("stiff_cantilever")
    result = solve_elastica(case, 20)
    tip = an.small_deflection_tip(case)
    drop = case.base_position[2] - result.centerline[:, 2]
    assert drop[-1] == pytest.approx(tip, rel=0.01)  # measured 0.14 % below
    linear = an.small_deflection_centerline(case, result.centerline.shape[0])
    assert np.max(np.abs(drop - (case.base_position[2] - linear[:, 2]))) < 0.01 * tip
    nonlinear = an.planar_elastica_centerline(case)
    assert centerline_error(result.centerline, nonlinear, case.length)[0] < 3e-5  # measured 1.4e-5


def test_soft_cantilever_converges_at_second_order():
    case = _case("soft_cantilever")
    reference = an.planar_elastica_centerline(case)
    coarse = solve_elastica(case, 20)
    fine = solve_elastica(case, 40)
    err_coarse = centerline_error(coarse.centerline, reference, case.length)[0]
    err_fine = centerline_error(fine.centerline, reference, case.length)[0]
    assert err_coarse < 1e-3  # measured 6.5e-4
    assert err_fine < 2.5e-4  # measured 1.6e-4
    assert err_coarse / err_fine > 3.0  # measured 4.1
    for result in (coarse, fine):
        np.testing.assert_allclose(result.centerline[0], case.base_position, atol=1e-15)
        assert result.engine == "pyelastica"
        assert result.settings["max_strain"] < 2e-4
        assert result.wall_time_s > 0.0


def test_perturbation_turns_only_the_start_shape_out_of_plane():
    # curl_hanging bends in the x-z plane (k2 toward d1 = +x); the perturbed start bends toward -d2 = +y.
    case = _case("curl_hanging")
    start = perturbed_start(case, 0.05)
    assert start.intrinsic_curvature == pytest.approx((-0.05 / case.length, 50.0))
    rod = build_rod(case, 20, initial="rest", perturbation=0.05)
    np.testing.assert_allclose(rod.rest_kappa, np.array([[0.0], [50.0], [0.0]]) * np.ones((1, 19)))
    out_of_plane = np.max(np.abs(rod.position_collection[1]))
    assert 1e-4 * case.length < out_of_plane < 0.05 * case.length  # measured 4.3e-4 L on this 2.4-turn coil
    assert np.all(build_rod(case, 20, initial="rest").position_collection[1] == 0.0)


def test_invalid_settings_are_rejected():
    case = _case("soft_cantilever")
    with pytest.raises(ParameterError, match="n_elements"):
        solve_elastica(case, 3)
    with pytest.raises(ParameterError, match="initial"):
        solve_elastica(case, 20, initial="bent")
    with pytest.raises(ParameterError, match="cfl"):
        solve_elastica(case, 20, cfl=1.5)
    with pytest.raises(ParameterError, match="perturbation"):
        solve_elastica(case, 20, perturbation=2.0)


def test_unconverged_run_is_flagged():
    case = _case("soft_cantilever")
    result = solve_elastica(case, 10, max_time_s=0.02)
    assert not result.settings["converged"]
    assert result.settings["sim_time_s"] >= 0.02


# Measured max/L errors at 50 elements against `reference_centerline` (closed form or BVP).
MEASURED_50 = {
    "arc_zero_gravity": 1.8e-4,
    "coil_zero_gravity": 8.7e-4,
    "curl_hanging": 6.5e-4,
    "curl_sideways_gravity": 1.6e-4,
    "helix_zero_gravity": 3.5e-4,
    "soft_cantilever": 1.0e-4,
    "stiff_cantilever": 2.2e-6,
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(MEASURED_50))
def test_case_files_at_50_elements(name):
    case = _case(name)
    reference, _ = an.reference_centerline(case)
    result = solve_elastica(case, 50)
    assert result.settings["converged"]
    assert centerline_error(result.centerline, reference, case.length)[0] < 1.5 * MEASURED_50[name]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["curl_sideways_gravity", "coil_zero_gravity"])
def test_case_files_converge_from_50_to_100_elements(name):
    # measured ratios: 4.1 (sideways), 4.0 (coil)
    case = _case(name)
    reference, _ = an.reference_centerline(case)
    errors = [
        centerline_error(solve_elastica(case, n).centerline, reference, case.length)[0]
        for n in (50, 100)
    ]
    assert errors[0] / errors[1] > 3.0
