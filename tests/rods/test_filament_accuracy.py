"""The harness filament against every rod case's reference (issue 11, item 2: "a filament that is right in 3D").

Reference per case (`comparison.reference_result`): the closed form or boundary-value solution, or for the
multi-turn hanging coils the stored PyElastica run at 200 elements (`tasks/rod_cases/references/`, read,
not rerun). Errors are max |x - x_ref| / L over the centerline (`comparison.case_error`: the nearer mirror
image on planar cases, which can buckle out of their plane either way). Measured values are in MEASURED
and in the README's accuracy table; they were taken on the project's 2-core x86_64 machine.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.filament import FilamentParams
from entangle_bench.presets import DEFAULT_PRESET, get_preset
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import RodCase, RodResult, centerline_error, load_case
from entangle_bench.rods.comparison import case_error, reference_result
from entangle_bench.rods.representations import solve_representation

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"
NAMES = sorted(p.stem for p in CASE_DIR.glob("*.json"))

#: Segments of the default preset's filament, and the resolution the grasp calibration needs.
DEFAULT_SEGMENTS = get_preset(DEFAULT_PRESET).n_segments
GRASP_SEGMENTS = 40

#: Issue 11's requirement: within 2 % of L on every rod case.
TOLERANCE = 0.02

#: Measured max error / L against the reference: hinge chain (`hinges`) at 16 and 40 segments, and the
#: isotropic ball chain (`ball`) at 16.
MEASURED = {
    "arc_zero_gravity": (1.5e-3, 2.3e-4, 1.5e-3),
    "coil12_sideways_gravity": (9.2e-2, 1.4e-2, 2.7e-1),
    "coil12_twisted_hanging": (3.3e-2, 4.3e-3, 8.7e-2),
    "coil12_vertical_plane_gravity": (1.1e-1, 1.8e-2, 2.8e-1),
    "coil5_planar_gravity": (7.5e-3, 1.2e-3, 7.5e-3),
    "coil5_sideways_gravity": (1.3e-2, 2.0e-3, 3.3e-2),
    "coil5_twisted_tilted_gravity": (1.1e-2, 1.6e-3, 4.4e-2),
    "coil_zero_gravity": (7.4e-3, 1.1e-3, 7.4e-3),
    "curl_hanging": (4.4e-2, 8.7e-4, 6.0e-3),
    "curl_sideways_gravity": (6.7e-3, 2.8e-3, 5.9e-2),
    "helix_zero_gravity": (2.9e-3, 4.5e-4, 2.9e-3),
    "soft_cantilever": (1.5e-3, 2.3e-4, 1.5e-3),
    "stiff_cantilever": (3.6e-5, 5.2e-6, 3.6e-5),
}

#: Where 16 segments miss the 2 % requirement (measured at 16 / 24 / 32 / 40 segments): the hinge springs are
#: quadratic in each joint's own angles, so large per-joint deviations from the rest shape (coarse chains in
#: strong gravity) cost accuracy; 40 segments meet it everywhere.
_MISS = "16 segments in strong gravity: {} L (24: {}, 32: {}, 40: {})"
COARSE_MISSES = {
    "coil12_sideways_gravity": _MISS.format("9.2e-2", "4.6e-2", "2.4e-2", "1.4e-2"),
    "coil12_twisted_hanging": _MISS.format("3.3e-2", "1.4e-2", "7.4e-3", "4.3e-3"),
    "coil12_vertical_plane_gravity": _MISS.format("1.1e-1", "5.3e-2", "3.0e-2", "1.8e-2"),
    "curl_hanging": _MISS.format("4.4e-2 (another equilibrium of the coarse chain)", "2.5e-3", "1.4e-3", "8.7e-4"),
}


def _case(name: str) -> RodCase:
    return load_case(CASE_DIR / f"{name}.json")


@cache
def _reference(name: str) -> RodResult:
    return reference_result(_case(name))


@cache
def _solve(name: str, representation: str, n_segments: int) -> RodResult:
    return solve_representation(_case(name), representation, n_segments)


def _error(name: str, representation: str, n_segments: int) -> float:
    case = _case(name)
    return case_error(case, _solve(name, representation, n_segments).centerline, _reference(name).centerline)[0]


def test_measured_table_covers_every_case():
    assert sorted(MEASURED) == NAMES
    assert set(COARSE_MISSES) <= set(NAMES)


def test_accurate_preset_resolves_the_hinge_filament_to_two_percent():
    """The accurate preset is fine enough for the 2 % requirement, which GRASP_SEGMENTS meets on every case
    (below). The default joint model stays the ball chain until the calibration re-derives the presets: at
    the coarse presets the hinge chain fails contact hard cases (README, *The model*)."""
    assert get_preset("accurate").n_segments >= GRASP_SEGMENTS
    assert FilamentParams().joints == "ball" and DEFAULT_SEGMENTS < GRASP_SEGMENTS


def _accuracy_params() -> list:
    params = []
    for name in NAMES:
        for n in (16, GRASP_SEGMENTS):
            marks = []
            if n == 16 and name in COARSE_MISSES:
                marks = [pytest.mark.xfail(strict=True, reason=COARSE_MISSES[name])]
            params.append(pytest.param(name, n, marks=marks, id=f"{name}-{n}"))
    return params


@pytest.mark.parametrize(("name", "n_segments"), _accuracy_params())
def test_hinge_filament_within_two_percent_of_reference(name, n_segments):
    error = _error(name, "hinges", n_segments)
    assert error < TOLERANCE
    # Regression guard: no worse than measured (see MEASURED).
    measured = MEASURED[name][0 if n_segments == 16 else 1]
    assert error < 1.3 * measured


# Tilted 3D cases: the isotropic ball spring (twist stiffness E I instead of G J) is measurably off. On
# coil12_vertical_plane_gravity its stiffer twist keeps the planar equilibrium stable, so it stays planar
# while the rod buckles out of plane.
ISOTROPIC_OFF = {
    "curl_sideways_gravity": 0.05,  # measured 5.9e-2
    "coil12_sideways_gravity": 0.05,  # measured 2.7e-1
    "coil12_twisted_hanging": 0.05,  # measured 8.7e-2
    "coil12_vertical_plane_gravity": 0.05,  # measured 2.8e-1
    "coil5_sideways_gravity": 0.025,  # measured 3.3e-2: a stiff 5 mm coil, less twist-bend coupling
    "coil5_twisted_tilted_gravity": 0.025,  # measured 4.4e-2
}


@pytest.mark.parametrize("name", sorted(ISOTROPIC_OFF))
def test_isotropic_ball_chain_is_off_on_tilted_3d_cases(name):
    isotropic = _error(name, "ball", GRASP_SEGMENTS)
    assert isotropic > ISOTROPIC_OFF[name]
    assert isotropic > TOLERANCE  # the accuracy test above would fail on the plain chain
    assert isotropic > 2.5 * _error(name, "hinges", GRASP_SEGMENTS)


@pytest.mark.parametrize("name", ["coil5_planar_gravity", "soft_cantilever"])
def test_hinges_change_nothing_on_stable_planar_cases(name):
    case = _case(name)
    hinge, plain = _solve(name, "hinges", GRASP_SEGMENTS), _solve(name, "ball", GRASP_SEGMENTS)
    assert case_error(case, hinge.centerline, plain.centerline)[0] < 1e-6


def test_twist_stiffness_decides_whether_the_planar_coil_buckles():
    # coil12_vertical_plane_gravity is planar by symmetry. With G J (the hinge chain and PyElastica) its
    # planar equilibrium is a saddle and the coil leaves the plane; the isotropic chain's twist stiffness
    # E I (1.49 G J) makes it stable, so that chain stays planar.
    name = "coil12_vertical_plane_gravity"
    case = _case(name)
    normal = np.array([0.0, 1.0, 0.0])

    def out_of_plane(result: RodResult) -> float:
        return float(np.max(np.abs((result.centerline - np.asarray(case.base_position)) @ normal))) / case.length

    assert out_of_plane(_reference(name)) > 0.05  # measured 6.5e-2
    hinge = _solve(name, "hinges", GRASP_SEGMENTS)
    assert out_of_plane(hinge) > 0.05
    assert hinge.settings["saddles_left"] >= 1  # measured 1: it left the planar saddle
    plain = _solve(name, "ball", 16)
    assert out_of_plane(plain) < 1e-9
    assert plain.settings["saddles_left"] == 0
    # That planar shape is the planar elastica's (measured 1.3e-2 at 16, 2.3e-3 at 40 segments), 0.28 L from
    # the stable 3D one.
    planar = an.planar_elastica_centerline(case)
    assert centerline_error(plain.centerline, planar, case.length)[0] < 0.02
    assert case_error(case, planar, _reference(name).centerline)[0] > 0.2


def test_hinge_chain_converges_in_3d():
    # coil5_sideways_gravity (3D, twist-bend coupling): 1.3e-2 at 16, 5.7e-3 at 24 and 3.2e-3 at 32 segments
    # (ratio 4.1 for 2x the segments; curl_sideways_gravity converges at first order: 6.7e-3 -> 3.4e-3).
    name = "coil5_sideways_gravity"
    coarse, fine = _error(name, "hinges", 16), _error(name, "hinges", 32)
    assert 3.0 < coarse / fine < 5.5
