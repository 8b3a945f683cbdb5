"""MuJoCo rod representations (the harness filament with joints `hinges` or `ball`, `cable`, `flex1d`) against the
analytic and BVP references."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import pytest

from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import centerline_error, load_case
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


def test_representation_names():
    assert REPRESENTATIONS.names() == ["ball", "cable", "flex1d", "hinges"]


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
    with pytest.raises(UnknownNameError, match="representation 'spaghetti'.*ball, cable, flex1d, hinges"):
        solve_representation(_case("soft_cantilever"), "spaghetti", 8)
