"""MuJoCo rod representations (the harness filament `ball`, its hinge-free `ball_isotropic`, `cable`, `flex1d`)
against the analytic and BVP references."""

from __future__ import annotations

import dataclasses
from functools import cache
from pathlib import Path

import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import centerline_error, load_case
from entangle_bench.rods.mujoco_engine import filament_params
from entangle_bench.rods.representations import REPRESENTATIONS, solve_representation

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"


def _case(name: str):
    return load_case(CASE_DIR / f"{name}.json")


@cache
def _reference(case):
    return an.reference_centerline(case)[0]


def _error(case, representation, n):
    reference = _reference(case)
    result = solve_representation(case, representation, n)
    return centerline_error(result.centerline, reference, case.length)[0]


def test_series_twist_hinge_gives_gj_compliance():
    # Springs in series: ds / GJ = 1 / k_hinge + ds / EI, with the harness filament's own hinge stiffness.
    case = _case("curl_sideways_gravity")
    params = filament_params(case, 4)
    ds = params.segment_length_m
    k = params.twist_hinge_stiffness_nm
    assert 1.0 / k + ds / case.bending_stiffness == pytest.approx(ds / case.twist_stiffness, rel=1e-12)
    assert filament_params(dataclasses.replace(case, poisson_ratio=0.0), 4).twist_hinge_stiffness_nm == float("inf")
    with pytest.raises(ParameterError, match="poisson_ratio"):
        filament_params(dataclasses.replace(case, poisson_ratio=-0.2), 4)
    assert filament_params(dataclasses.replace(case, poisson_ratio=-0.2), 4, twist_hinge=False).twist_hinge is False


def test_representation_names():
    assert REPRESENTATIONS == ("ball", "ball_isotropic", "cable", "flex1d")


def test_twist_hinge_fixes_sideways_curl_at_second_order():
    # The harness filament `ball` (series twist hinge about the rest mid-tangent): 6.2e-3 at 8 and 1.5e-3 at
    # 16 segments; the hinge-free `ball_isotropic` chain stays 6.0e-2 L off at any resolution.
    case = _case("curl_sideways_gravity")
    coarse, fine = _error(case, "ball", 8), _error(case, "ball", 16)
    assert fine < 3e-3
    assert 3.0 < coarse / fine < 5.0
    assert _error(case, "ball_isotropic", 16) > 0.05


def test_cable_plugin_matches_soft_cantilever():
    # Composite cable with the elasticity plugin: 9.3e-4 L at 16 segments.
    assert _error(_case("soft_cantilever"), "cable", 16) < 2e-3


def test_flex1d_bends_like_the_elastica_and_refuses_curved_cases():
    # 1D flex elasticity (MuJoCo 3.17): 1.8e-3 L at 16 segments on the soft cantilever.
    assert _error(_case("soft_cantilever"), "flex1d", 16) < 4e-3
    with pytest.raises(ParameterError, match="straight reference configuration"):
        solve_representation(_case("arc_zero_gravity"), "flex1d", 16)
    with pytest.raises(ParameterError, match="must exceed the diameter"):
        solve_representation(_case("soft_cantilever"), "flex1d", 40)


def test_unknown_representation_is_rejected():
    with pytest.raises(ParameterError, match="representation"):
        solve_representation(_case("soft_cantilever"), "spaghetti", 8)
