"""The harness filament at static equilibrium against analytic, BVP and PyElastica answers: joint model "hinges"
(twist, out-of-plane and in-plane hinges per segment) and "ball" (one isotropic ball joint per segment).

Errors are max |x - x_ref| / L over the centerline at uniform arclength; measured values (in comments) were
taken with the presets of entangle_bench/presets.py.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.filament import rest_hinges, rest_rotation_quat
from entangle_bench.presets import get_preset
from entangle_bench.rods import analytic as an
from entangle_bench.rods.case import centerline_error, load_case
from entangle_bench.rods.elastica_engine import solve_elastica
from entangle_bench.rods.mujoco_engine import build_rod, stiffness_matrix
from entangle_bench.rods.representations import solve_representation

CASE_DIR = Path(__file__).resolve().parents[2] / "tasks" / "rod_cases"


def _case(name: str):
    return load_case(CASE_DIR / f"{name}.json")


def test_arc_within_one_percent_at_accurate():
    # Issue requirement: closed-form arc within 1 % of L with the accurate preset (measured 2.3e-4).
    case = _case("arc_zero_gravity")
    result = solve_representation(case, "ball", preset="accurate")
    error, _ = centerline_error(result.centerline, an.rest_centerline(case), case.length)
    assert error < 0.01
    assert result.settings["n_segments"] == get_preset("accurate").n_segments


def test_stiff_cantilever_within_two_percent_of_small_deflection_formula():
    # Issue requirement: tip drop q L^4 / (8 E I) within 2 % (measured 0.9 %, of which 0.7 % is the
    # formula's own linearisation), at the default preset.
    case = _case("stiff_cantilever")
    result = solve_representation(case, "ball")
    drop = case.base_position[2] - result.centerline[-1, 2]
    assert drop == pytest.approx(an.small_deflection_tip(case), rel=0.02)


def test_soft_cantilever_within_three_percent_of_pyelastica_at_balanced():
    # Issue requirement: 3 % of L against PyElastica at balanced (measured 1.5e-3 against 50 elements;
    # 12 elements are themselves within 3e-3 L of the elastica BVP).
    case = _case("soft_cantilever")
    mujoco_result = solve_representation(case, "ball", preset="balanced")
    reference = solve_elastica(case, 12)
    error, _ = centerline_error(mujoco_result.centerline, reference.centerline, case.length)
    assert error < 0.03
    assert error > 1e-5  # two different discretizations: a zero here would mean one was not run


def test_chain_converges_at_second_order_on_the_arc():
    # Halving the segment length must cut the error about 4x (measured 1.46e-3 -> 3.7e-4).
    case = _case("arc_zero_gravity")
    exact = an.rest_centerline(case)
    errors = [
        centerline_error(solve_representation(case, "ball", n).centerline, exact, case.length)[0]
        for n in (16, 32)
    ]
    assert 3.0 < errors[0] / errors[1] < 5.0


def test_hanging_curl_leaves_the_unstable_planar_branch():
    # The plain ball chain at 16 segments used to stop on a saddle 0.1 L from the BVP answer; with the stability
    # check it reaches the stable branch (measured 6.0e-3) and records that it had to leave a saddle. The
    # hinge chain (default) relaxes along another path that visits no saddle, to the same planar equilibrium
    # (twist plays no part in a planar shape).
    case = _case("curl_hanging")
    exact = an.planar_elastica_centerline(case)
    isotropic = solve_representation(case, "ball", preset="balanced")
    error, _ = centerline_error(isotropic.centerline, exact, case.length)
    assert error < 0.012
    assert isotropic.settings["saddles_left"] >= 1
    assert isotropic.settings["representation"] == "ball"
    # The hinge chain's springs are nonlinear in large per-joint deviations: at 16 segments it settles 4.4e-2 L
    # away (another equilibrium of the coarse chain); from 20 segments on it matches the ball chain.
    hinge = solve_representation(case, "hinges", 24)
    assert centerline_error(hinge.centerline, exact, case.length)[0] < 0.004
    assert centerline_error(hinge.centerline, solve_representation(case, "ball", 24).centerline, case.length)[0] < 1e-4


def test_isotropic_twist_spring_explains_the_sideways_curl_error():
    # The ball joint has one stiffness, E I / ds, also for twist. With nu = 0 (G J = E I) the chain agrees
    # with the 3D Kirchhoff BVP to 4e-4 L at 32 segments; with nu = 0.5 it stays 6e-2 L off.
    case = _case("curl_sideways_gravity")
    isotropic = dataclasses.replace(case, poisson_ratio=0.0)
    error_iso, _ = centerline_error(
        solve_representation(isotropic, "ball", 32).centerline,
        an.kirchhoff_centerline(isotropic),
        case.length,
    )
    exact = an.kirchhoff_centerline(case)
    error_real, _ = centerline_error(
        solve_representation(case, "ball", 32).centerline, exact, case.length
    )
    assert error_iso < 1e-3
    assert error_real > 0.03
    # The hinge chain's twist hinge gives G J: measured 3.2e-3 at 32 segments (first order in 3D).
    error_hinge, _ = centerline_error(solve_representation(case, "hinges", 32).centerline, exact, case.length)
    assert error_hinge < 4e-3


def test_stiffness_matrix_of_straight_rod_is_the_joint_stiffness():
    # Zero gravity, straight rest shape, plain ball chain: the generalized stiffness is diagonal with 2 EI/ds at
    # the clamp and EI/ds elsewhere, for all three rotational dofs (isotropic ball springs).
    case = dataclasses.replace(_case("soft_cantilever"), gravity=(0.0, 0.0, 0.0))
    n = 5
    model, _, _ = build_rod(case, n, get_preset("balanced").numerics, joints="ball")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    k = case.bending_stiffness / (case.length / n)
    expected = np.diag(np.repeat([2 * k] + [k] * (n - 1), 3))
    np.testing.assert_allclose(stiffness_matrix(model, data), expected, rtol=1e-6, atol=1e-6 * k)


def test_unsettled_rod_raises_naming_the_case():
    case = _case("soft_cantilever")
    with pytest.raises(ParameterError, match="soft_cantilever"):
        solve_representation(case, "ball", max_time_s=0.05)


def test_hinge_chain_stiffness_is_the_anisotropic_rod_stiffness():
    # Straight rest shape, zero gravity: per segment twist GJ/ds, out-of-plane and in-plane bending EI/ds
    # (a solid rod has I_side = I_bend), doubled at the clamp.
    case = dataclasses.replace(_case("soft_cantilever"), gravity=(0.0, 0.0, 0.0))
    n = 5
    model, _, _ = build_rod(case, n, get_preset("balanced").numerics, joints="hinges")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    ds = case.length / n
    per_joint = np.array([case.twist_stiffness, case.bending_stiffness, case.bending_stiffness]) / ds
    expected = np.diag(np.concatenate([2 * per_joint] + [per_joint] * (n - 1)))
    np.testing.assert_allclose(stiffness_matrix(model, data), expected, rtol=1e-6, atol=1e-6 * per_joint.max())


def test_hinge_chain_fixes_the_sideways_curl():
    # The ball chain is 6.0e-2 L off at any resolution (twist stiffness EI); the hinge chain has GJ:
    # measured 6.7e-3 L at 16 and 2.8e-3 L at 40 segments (first order in 3D).
    case = _case("curl_sideways_gravity")
    reference = an.reference_centerline(case)[0]
    errors = [
        centerline_error(solve_representation(case, "hinges", n).centerline, reference, case.length)[0]
        for n in (16, 40)
    ]
    assert errors[1] < 4e-3
    assert 1.8 < errors[0] / errors[1] < 4.0


def test_rest_hinges_reproduce_the_rest_rotation_with_rest_twist():
    darboux = np.array([30.0, 40.0, -80.0])
    axes, angles = rest_hinges(darboux, 0.01)
    for j, portion in enumerate((0.005, 0.01)):
        quat = np.array([1.0, 0.0, 0.0, 0.0])
        for axis, angle in zip(axes[j], angles[j]):
            step = np.empty(4)
            mujoco.mju_axisAngle2Quat(step, axis, angle)
            mujoco.mju_mulQuat(quat, quat.copy(), step)
        target = rest_rotation_quat(darboux, portion)
        np.testing.assert_allclose(quat * np.sign(quat @ target), target, atol=1e-12)


def _swing_tip(numerics, joints: str = "hinges", steps: int = 400) -> np.ndarray:
    """Tip of a straight 300 mm rod clamped horizontally, released in gravity: (steps / 20, 3) samples, m."""
    case = dataclasses.replace(_case("soft_cantilever"), length=0.3)
    model, _, names = build_rod(case, 12, numerics, damping_time_s=0.01, joints=joints)
    data = mujoco.MjData(model)
    tip = model.body(names[-1]).id
    samples = []
    for _ in range(steps // 20):
        mujoco.mj_step(model, data, 20)
        samples.append(data.xpos[tip].copy())
    return np.array(samples)


def test_twist_only_armature_leaves_a_planar_swing_as_without_armature():
    # A planar swing never twists the rod, so armature on the twist hinges alone (bending_armature False)
    # must leave it exactly as without any armature; on every DOF (the default) it slows the swing.
    base = dataclasses.replace(get_preset("balanced").numerics, timestep_s=2.5e-4, integrator="implicitfast")
    plain = _swing_tip(dataclasses.replace(base, twist_armature_scale=1.0))
    twist_only = _swing_tip(dataclasses.replace(base, twist_armature_scale=1000.0, bending_armature=False))
    everywhere = _swing_tip(dataclasses.replace(base, twist_armature_scale=1000.0))
    assert np.abs(twist_only - plain).max() < 1e-9
    assert np.abs(everywhere - plain).max() > 1e-4  # m; measured 4.4e-4 after 0.1 s: heavier bending at the tip


def test_twist_only_armature_needs_hinges():
    numerics = dataclasses.replace(get_preset("balanced").numerics, bending_armature=False)
    with pytest.raises(ParameterError, match="bending_armature.*hinges.*ball"):
        numerics.check_joints("ball")
    with pytest.raises(ParameterError, match="bending_armature"):
        build_rod(_case("soft_cantilever"), 12, numerics, joints="ball")
    from entangle_bench.suite import resolve_config

    with pytest.raises(ParameterError, match="bending_armature"):  # a task's configuration, before any build
        resolve_config("eight_branch_tree", "balanced", ["numerics.bending_armature=false"])
    hinged = resolve_config("eight_branch_tree", "balanced",
                            ["numerics.bending_armature=false", "gripper.filament.joints=hinges"])
    assert not hinged.numerics.bending_armature
