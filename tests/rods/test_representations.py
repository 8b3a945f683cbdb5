"""Alternative MuJoCo rod representations (study only) against the analytic and BVP references."""

from __future__ import annotations

import dataclasses
from functools import cache
from pathlib import Path

import pytest

from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import centerline_error, load_case
from entangle_bench.rods.representations import series_twist_stiffness, solve_representation

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
    # Springs in series: ds / GJ = 1 / k_hinge + ds / EI.
    case = _case("curl_sideways_gravity")
    ds = 0.01
    k = series_twist_stiffness(case, ds)
    assert 1.0 / k + ds / case.bending_stiffness == pytest.approx(ds / case.twist_stiffness, rel=1e-12)
    assert series_twist_stiffness(dataclasses.replace(case, poisson_ratio=0.0), ds) == float("inf")
    with pytest.raises(ParameterError, match="poisson_ratio"):
        series_twist_stiffness(dataclasses.replace(case, poisson_ratio=-0.2), ds)


def test_twist_hinge_fixes_sideways_curl_at_second_order():
    # The harness chain is 6e-2 L off (isotropic twist); with the series twist hinge about the rest
    # mid-tangent: 6.2e-3 at 8 and 1.5e-3 at 16 segments.
    case = _case("curl_sideways_gravity")
    coarse, fine = _error(case, "ball_twist", 8), _error(case, "ball_twist", 16)
    assert fine < 3e-3
    assert 3.0 < coarse / fine < 5.0


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


def test_unknown_representation_is_rejected_listing_the_known_ones():
    with pytest.raises(UnknownNameError, match="representation 'spaghetti'.*ball, ball_twist, cable, flex1d"):
        solve_representation(_case("soft_cantilever"), "spaghetti", 8)
