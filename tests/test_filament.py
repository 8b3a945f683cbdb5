"""Physics of one filament against closed-form answers."""

import math

import mujoco
import numpy as np
import pytest

from entangle_bench import effects as fx
from entangle_bench.errors import ParameterError
from entangle_bench.filament import MODAL_STRETCH_ARMATURE_RATIO, REFERENCE_COIL_RADIUS_M, FilamentParams, stretch_name
from entangle_bench.scene import step_until_rest


def fit_circle_xz(points: np.ndarray) -> float:
    """Least-squares (Kasa) circle radius of points in the x-z plane, m."""
    a = np.c_[2 * points[:, 0], 2 * points[:, 2], np.ones(len(points))]
    b = points[:, 0] ** 2 + points[:, 2] ** 2
    cx, cz, c = np.linalg.lstsq(a, b, rcond=None)[0]
    return math.sqrt(c + cx**2 + cz**2)


def settled_centerline(scene, pressure_pa=0.0, gravity=None, max_time_s=20.0):
    model, data = scene.model, mujoco.MjData(scene.model)
    if gravity is not None:
        model.opt.gravity[:] = gravity
    scene.gripper.set_pressure(model, pressure_pa, np.array([0.0]))
    assert step_until_rest(model, data, max_time_s, 1e-5, kinetic_damping=True), "no rest"
    return scene.gripper.centerlines(model, data)[0]


def test_default_calibration_gives_stated_coil_radius():
    params = FilamentParams()
    assert params.curvature_per_m(172e3) == pytest.approx(1.0 / REFERENCE_COIL_RADIUS_M)
    # The law is linear in pressure and in eps, and falls with r and E.
    assert params.curvature_per_m(86e3) == pytest.approx(0.5 / REFERENCE_COIL_RADIUS_M)
    stiffer = FilamentParams(youngs_modulus_pa=2e6)
    assert stiffer.curvature_per_m(172e3) == pytest.approx(0.5 / REFERENCE_COIL_RADIUS_M)


def test_actuated_coil_radius_matches_curvature(single_filament_scene):
    """Zero gravity, no contact: the coil's fitted radius is 1/kappa within 2 % (40 segments)."""
    scene = single_filament_scene(n_segments=40)
    kappa = scene.config.gripper.filament.curvature_per_m(172e3)
    line = settled_centerline(scene, pressure_pa=172e3)
    assert np.ptp(line[:, 1]) < 1e-9  # stays in its bending plane
    assert fit_circle_xz(line) * kappa == pytest.approx(1.0, abs=0.02)


@pytest.mark.parametrize("joints, armature", [("ball", 0.0), ("hinges", 0.0), ("hinges", MODAL_STRETCH_ARMATURE_RATIO)])
def test_stretch_at_clamp_carries_the_hanging_weight_by_hookes_law(single_filament_scene, joints, armature):
    # The slide joint at the clamp holds the whole filament: extension W / (E A / L) at rest, and the
    # clamp's tension is then bounded by the stretch (E A / L), not by what a kinematic hub demands. The
    # joint's armature changes no equilibrium.
    scene = single_filament_scene(effects=fx.Effects(gravity=True, filament_self_contact=False,
                                                     filament_filament_contact=False, ground_contact=False,
                                                     filament_object_contact=False),
                                  stretch_at_clamp=True, stretch_armature_ratio=armature, joints=joints,
                                  youngs_modulus_pa=0.05e6)
    params = scene.config.gripper.filament
    straight = settled_centerline(scene, gravity=(0.0, 0.0, 0.0))
    hanging = settled_centerline(scene, gravity=(0.0, 0.0, -9.81))
    expected = params.mass_kg * 9.81 / params.axial_stiffness_n_m  # 2x a continuous rod's rho g L^2 / (2 E)
    assert expected > 1e-3  # a soft filament, so the stretch is well above the solver's tolerance
    assert straight[0, 2] - hanging[0, 2] == pytest.approx(expected, rel=0.01)  # the clamp end moved down
    assert np.linalg.norm(np.diff(hanging, axis=0), axis=1).sum() == pytest.approx(params.length_m, rel=1e-9)


@pytest.mark.parametrize("pressure_pa", [0.0, 172e3])
def test_stretch_armature_keeps_the_joint_below_the_rods_first_axial_frequency(single_filament_scene, pressure_pa):
    """The stretch joint's fastest motion, sqrt(k / m_eff) with m_eff = 1 / (M^-1)_ss (every other joint free),
    against a clamped-free rod's first axial frequency (pi / 2) sqrt(E A / (m L)): with the modal armature at or
    below it, straight and coiled; without armature a coil lets the joint move little more than the first
    segments (m_eff < 0.1 m), a mode over twice as fast, which the explicit damping cannot follow."""
    ratios = {}
    for armature in (0.0, MODAL_STRETCH_ARMATURE_RATIO):
        scene = single_filament_scene(n_segments=40, joints="hinges", stretch_at_clamp=True,
                                      stretch_armature_ratio=armature)
        model, data = scene.model, mujoco.MjData(scene.model)
        scene.gripper.set_pressure(model, pressure_pa, np.array([0.0]))
        data.qpos[:] = model.qpos_spring  # the rest shape: straight, or the coil of 172 kPa
        mujoco.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        dof = model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, stretch_name(0))]
        params = scene.config.gripper.filament
        m_eff = 1.0 / np.linalg.inv(mass)[dof, dof]
        rod = math.pi / 2 * math.sqrt(params.axial_stiffness_n_m / params.mass_kg)
        ratios[armature] = math.sqrt(params.axial_stiffness_n_m / m_eff) / rod
    assert ratios[MODAL_STRETCH_ARMATURE_RATIO] <= 1.0
    if pressure_pa > 0:
        assert ratios[0.0] > 2.0
    else:  # straight: the joint moves the whole filament, 2 / pi of the rod's frequency
        assert ratios[0.0] == pytest.approx(2 / math.pi, rel=1e-6)


def test_stretch_armature_needs_the_stretch_joint():
    with pytest.raises(ParameterError, match="stretch_at_clamp"):
        FilamentParams(stretch_armature_ratio=0.4)


def test_stiff_cantilever_matches_small_deflection_formula(single_filament_scene):
    """Sideways gravity on a stiff clamped rod: tip drop rho A g L^4 / (8 EI) within 5 %."""
    scene = single_filament_scene(effects=fx.NO_CONTACT, n_segments=20, youngs_modulus_pa=2e10)
    params = scene.config.gripper.filament
    line = settled_centerline(scene, gravity=(-9.81, 0.0, 0.0))
    expected = params.linear_density_kg_m * 9.81 * params.length_m**4 / (
        8 * params.bending_stiffness_nm2
    )
    assert expected / params.length_m < 0.03  # small-deflection regime
    assert -line[-1, 0] == pytest.approx(expected, rel=0.05)


def test_doubling_segments_changes_equilibrium_little(single_filament_scene):
    """Actuated filament hanging under gravity: 16 -> 32 segments moves the centerline < 2 % of L."""
    lines = []
    for n in (16, 32):
        scene = single_filament_scene(effects=fx.NO_CONTACT, n_segments=n)
        lines.append(settled_centerline(scene, pressure_pa=60e3))
    coarse, fine = lines
    # compare at the coarse vertices: every other vertex of the fine line
    err = np.max(np.linalg.norm(coarse - fine[::2], axis=1)) / 0.3
    assert err < 0.02


def test_energy_does_not_grow_with_damping(single_filament_scene):
    """Released from a bent pose with constant rest shape, mechanical energy never rises."""
    scene = single_filament_scene(effects=fx.NO_CONTACT, n_segments=16)
    model, data = scene.model, mujoco.MjData(scene.model)
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    scene.gripper.set_pressure(model, 172e3, np.array([0.0]))
    mujoco.mj_step(model, data, 200)  # bend the rod under actuation
    scene.gripper.set_pressure(model, 0.0, np.array([0.0]))  # release: rest shape is straight
    energies, kinetic = [], []
    for _ in range(300):
        mujoco.mj_step(model, data, 5)
        energies.append(data.energy.sum())
        kinetic.append(data.energy[1])
    energies = np.array(energies)
    assert max(kinetic) > 1e-6  # the rod really swings back
    assert energies[0] - energies[-1] > 10 * max(kinetic[-1], 1e-9)  # and loses energy
    assert np.all(np.diff(energies) <= 1e-9 * abs(energies[0]))


@pytest.mark.parametrize(
    "field, value, fragment",
    [
        ("length_m", 0.0, "filament.length_m"),
        ("length_m", -1.0, "filament.length_m"),
        ("n_segments", 1, "filament.n_segments"),
        ("channel_eccentricity", 1.5, "filament.channel_eccentricity"),
        ("channel_radius_ratio", 1.0, "filament.channel_radius_ratio"),
        ("youngs_modulus_pa", 0.0, "filament.youngs_modulus_pa"),
    ],
)
def test_bad_filament_parameters_name_the_parameter(field, value, fragment):
    with pytest.raises(ParameterError, match=fragment) as info:
        FilamentParams(**{field: value})
    assert "allowed range" in str(info.value) or "integer" in str(info.value)
