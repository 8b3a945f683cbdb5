"""Gripper layout, validation and the default array hanging in air."""

import math

import mujoco
import numpy as np
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.filament import FilamentParams
from entangle_bench.gripper import GripperParams, bending_angles, filament_positions
from entangle_bench.presets import DEFAULT_PRESET, PRESETS, apply_preset
from entangle_bench.scene import SceneConfig, build_scene


def test_reference_layout():
    params = GripperParams()
    pts = filament_positions(params)
    radii = np.sort(np.linalg.norm(pts, axis=1))
    assert params.n_filaments == 12
    assert np.allclose(radii[:4], 0.0125) and np.allclose(radii[4:], 0.025)
    # phi_G = r^2 / d^2: the outer ring's spacing is 2 R sin(pi/8); inner-ring filaments are nearer
    d_outer = 0.05 * math.sin(math.pi / 8)
    assert params.areal_density > (0.7e-3 / d_outer) ** 2 * 0.5


def test_hex_layout_and_density():
    params = GripperParams(layout="hex", hex_spacing_m=0.01, hex_rings=2)
    assert params.n_filaments == 19
    assert params.areal_density == pytest.approx((0.7e-3 / 0.01) ** 2)


def test_overlapping_filaments_are_rejected():
    with pytest.raises(ParameterError, match="overlap"):
        GripperParams(layout="hex", hex_spacing_m=0.001)


def test_bad_layouts_name_the_parameter():
    with pytest.raises(ParameterError, match="ring_counts"):
        GripperParams(ring_diameters_m=(0.05,), ring_counts=(8, 4))
    with pytest.raises(ParameterError, match="gripper.layout"):
        GripperParams(layout="spiral")
    with pytest.raises(ParameterError, match="hub_radius_m"):
        GripperParams(ring_diameters_m=(0.2,), ring_counts=(8,))


def test_random_bending_planes_are_seeded():
    params = GripperParams()
    a = bending_angles(params, np.random.default_rng(3))
    b = bending_angles(params, np.random.default_rng(3))
    c = bending_angles(params, np.random.default_rng(4))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    with pytest.raises(ParameterError, match="seeded"):
        bending_angles(params, None)


@pytest.mark.parametrize("preset", ["fast", "balanced"])
def test_default_array_actuates_in_air_without_warnings(preset):
    """12 filaments, 3 s hanging in air with a pressure ramp: finite state, no MuJoCo warnings, curled."""
    scene = build_scene(apply_preset(SceneConfig(), preset))
    model, data = scene.model, mujoco.MjData(scene.model)
    angles = bending_angles(scene.config.gripper, np.random.default_rng(0))
    mujoco.mj_kinematics(model, data)
    straight = scene.gripper.centerlines(model, data)
    while data.time < 3.0:
        scene.gripper.set_pressure(model, 172e3 * min(1.0, data.time / 1.0), angles)
        mujoco.mj_step(model, data, 10)
    assert np.all(np.isfinite(data.qpos)) and np.all(np.isfinite(data.qvel))
    assert all(w.number == 0 for w in data.warning)
    curled = scene.gripper.centerlines(model, data)
    # Gravity dominates (L / l_g ~ 13): roots hang straight, the tips curl, shortening every filament.
    span = np.linalg.norm(curled[:, -1] - curled[:, 0], axis=1)
    assert np.all(span < 0.93 * np.linalg.norm(straight[:, -1] - straight[:, 0], axis=1))


def test_preset_sets_segment_count_and_numerics_only():
    base = SceneConfig(gripper=GripperParams(pressure_pa=1e5))
    config = apply_preset(base, "fast")
    assert config.gripper.filament.n_segments == 12 and config.numerics == PRESETS["fast"].numerics
    assert config.gripper.pressure_pa == 1e5 and config.effects == base.effects
    scene = build_scene(config)
    assert scene.model.nbody == 1 + 1 + 12 * 12 + 0
    assert apply_preset(base) == apply_preset(base, DEFAULT_PRESET)


def test_filament_default_segments_are_the_default_presets():
    assert FilamentParams().n_segments == PRESETS[DEFAULT_PRESET].n_segments
    assert apply_preset(SceneConfig()) == SceneConfig()  # the defaults are already the default preset


def _rest_pose(model: mujoco.MjModel) -> np.ndarray:
    """Body orientations (nbody, 4) with every joint at its spring reference, sign-fixed quaternions."""
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos_spring
    mujoco.mj_kinematics(model, data)
    return data.xquat * np.sign(data.xquat[:, :1] + 1e-300)


@pytest.mark.parametrize("joints", ["hinges", "ball"])
def test_actuated_rest_shape_matches_per_filament_solution(joints):
    # set_pressure turns one solution about x for every curl axis and keeps the hinge axes at the
    # full-pressure triad; its rest pose must equal solving each filament's own rest shape (set_rest).
    filament = FilamentParams(n_segments=6, joints=joints, twist_ratio=0.3)
    params = GripperParams(filament=filament, ring_diameters_m=(0.02,), ring_counts=(3,))
    scene = build_scene(SceneConfig(gripper=params))
    model, gripper = scene.model, scene.gripper
    angles = np.array([0.3, 2.0, -1.2])
    axes = gripper.bend_axes(angles)
    for pressure in (100e3, params.pressure_pa):
        kappa = gripper.set_pressure(model, pressure, angles)
        shared = (model.jnt_axis.copy(), model.qpos_spring.copy(), _rest_pose(model))
        darboux = kappa * axes
        darboux[:, 0] += 0.3 * kappa
        gripper.joints.set_rest(model, darboux, filament.segment_length_m, axes)
        np.testing.assert_allclose(shared[2], _rest_pose(model), atol=1e-9)
    # at full pressure the axes are the rest shape's own material triad
    np.testing.assert_allclose(model.jnt_axis, shared[0], atol=1e-9)
    np.testing.assert_allclose(model.qpos_spring, shared[1], atol=1e-9)


def test_actuation_keeps_hinge_axes_fixed():
    # Rewriting axes while the hinges are off their rest angles would move segments without a velocity.
    filament = FilamentParams(n_segments=6, joints="hinges")
    params = GripperParams(filament=filament, ring_diameters_m=(0.02,), ring_counts=(3,))
    scene = build_scene(SceneConfig(gripper=params))
    model, gripper = scene.model, scene.gripper
    angles = np.array([0.3, 2.0, -1.2])
    gripper.set_pressure(model, 0.0, angles)
    straight_axes = model.jnt_axis.copy()
    gripper.set_pressure(model, 80e3, angles)
    np.testing.assert_array_equal(model.jnt_axis, straight_axes)
    data = mujoco.MjData(model)
    data.qpos[:] = np.random.default_rng(0).normal(0.0, 0.2, model.nq)
    mujoco.mj_kinematics(model, data)
    before = data.xpos.copy()
    gripper.set_pressure(model, 160e3, angles)
    mujoco.mj_kinematics(model, data)
    np.testing.assert_array_equal(data.xpos, before)
