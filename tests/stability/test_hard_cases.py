"""Hard cases under every preset: no NaN/Inf, no MuJoCo warning; energy, speed, depth bounded.

Each case runs the short top-drape trial of the default tree (or, for the tight coil, a probe in
air) at the preset's numerics. Where the case lies outside the preset's measured stability envelope,
the envelope must say so before the run, and the case runs at the envelope's timestep instead: that
is the contract a user gets. The accurate preset's trial cases take minutes each and are marked
slow.
"""

import dataclasses
import math

import pytest

from entangle_bench import effects as fx
from entangle_bench import stability
from entangle_bench.filament import FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import get_preset
from entangle_bench.suite.probe import ProbeConfig

from .conftest import CANDIDATE

#: The presets, and the calibration candidate's numerics (`conftest.CANDIDATE`; minutes per case, slow).
PRESETS = ["fast", "balanced", pytest.param("accurate", marks=pytest.mark.slow),
           pytest.param(CANDIDATE, marks=pytest.mark.slow)]
ALL_PRESETS = ["fast", "balanced", "accurate"]
REFERENCE = FilamentParams()


def assert_sound(run, limits):
    """The watchdog never tripped and its worst values are inside the bounds."""
    stats = run.result.stats
    assert run.result.stable and run.result.reason == "", run.describe()
    assert run.finite and not run.warnings, run.describe()
    assert stats.max_penetration_m <= limits.max_penetration_m, run.describe()
    assert stats.max_speed_m_s <= limits.max_speed_m_s, run.describe()
    assert stats.min_energy_margin_j >= 0.0, run.describe()


def assert_envelope_honest(run):
    """If the case ran below the preset's timestep, the envelope warned about that timestep."""
    clipped = run.config.numerics.timestep_s < run.preset_timestep_s
    assert clipped == any("timestep" in w for w in run.preset_warnings), run.preset_warnings


def same_coil_pressure(modulus_pa: float) -> float:
    """Pressure curling a filament of this modulus to the 12.5 mm reference coil (kappa ~ p/E)."""
    return 172e3 * modulus_pa / REFERENCE.youngs_modulus_pa


#: Fine segmentation for the stiff case: 24 segments (12.5 mm, twice the fast preset's), or the
#: preset's own when finer.
FINE_SEGMENTS = 24


@pytest.mark.parametrize("preset", PRESETS)
def test_very_stiff_finely_segmented_filaments(preset, resolve_case, run_trial_case, limits):
    """E = 10 MPa, finely segmented, same coil: the fastest bending waves of the suite.

    Outside the euler presets' envelope at their own timestep: they run at the envelope's 1 ms.
    """
    n = max(FINE_SEGMENTS, resolve_case(preset, []).gripper.filament.n_segments)
    config = resolve_case(
        preset,
        [
            "gripper.filament.youngs_modulus_pa=1e7",
            f"gripper.pressure_pa={same_coil_pressure(1e7)}",
            f"gripper.filament.n_segments={n}",
        ],
    )
    run = run_trial_case(config)
    assert_sound(run, limits)
    assert_envelope_honest(run)


@pytest.mark.parametrize("preset", PRESETS)
def test_very_soft_filaments(preset, resolve_case, run_trial_case, limits):
    """E = 0.05 MPa (same coil): the filament hangs like a string, l / l_g = 35 (27 for the candidate's 1 mm
    radius)."""
    config = resolve_case(
        preset,
        [
            "gripper.filament.youngs_modulus_pa=5e4",
            f"gripper.pressure_pa={same_coil_pressure(5e4)}",
        ],
    )
    assert config.gripper.filament.length_m / config.gripper.filament.gravity_length_m > 25
    run = run_trial_case(config)
    assert_sound(run, limits)
    assert_envelope_honest(run)


@pytest.mark.parametrize("preset", PRESETS)
def test_heavy_object(preset, resolve_case, run_trial_case, limits):
    """An object of 50 times the gripper's mass (it stays down; the filaments strain on it)."""
    config = resolve_case(preset, [])
    mass = 50 * config.gripper.n_filaments * config.gripper.filament.mass_kg
    config = dataclasses.replace(config, object=dataclasses.replace(config.object, mass_kg=mass))
    run = run_trial_case(config)
    assert_sound(run, limits)


@pytest.mark.parametrize("preset", ALL_PRESETS)
@pytest.mark.parametrize("contact", ["none", pytest.param("self", marks=pytest.mark.slow)])
def test_tightest_actuation_curvature(preset, contact, run_probe_case, limits):
    """Coil radius 3 filament radii (the tightest the law is used for), 2 rad per segment.

    One filament in air (a 12-filament trial at 72 segments would take minutes): 23 turns of a
    2.1 mm coil, the stiffest rest shape the actuation law produces. Without contact in CI; with
    self-contact (the turns stack, the coil limit asks for 0.23 ms) as a slow case.
    """
    kappa = 1.0 / (stability.MIN_COIL_RADIUS_RATIO * REFERENCE.outer_radius_m)
    n = math.ceil(kappa * REFERENCE.length_m / stability.MAX_TURN_PER_SEGMENT_RAD)
    pressure = 172e3 * kappa / REFERENCE.curvature_per_m(172e3) * (1 - 1e-9)
    gripper = GripperParams(
        filament=dataclasses.replace(REFERENCE, n_segments=n),
        ring_diameters_m=(0.0,),
        ring_counts=(1,),
        pressure_pa=pressure,
    )
    effects = fx.NO_CONTACT
    if contact == "self":
        effects = dataclasses.replace(effects, filament_self_contact=True)
    config = ProbeConfig(gripper=gripper, effects=effects, numerics=get_preset(preset).numerics)
    warnings = stability.envelope_warnings(config)
    assert not [w for w in warnings if "under-resolved" in w or "radii" in w], warnings
    result = run_probe_case(config)
    assert result.stable, (result.reason, result.time_s, result.stats)
    assert result.stats.max_speed_m_s < limits.max_speed_m_s
    assert result.stats.max_penetration_m <= limits.max_penetration_m
    assert result.stats.min_energy_margin_j >= 0


@pytest.mark.parametrize("preset", PRESETS)
def test_dense_array_of_48_filaments(preset, resolve_case, run_trial_case, limits):
    """48 filaments on three rings (24, 16, 8) inside the 50 mm circle, 6.5 mm apart."""
    config = resolve_case(preset, [])
    gripper = dataclasses.replace(
        config.gripper, ring_diameters_m=(0.05, 0.034, 0.018), ring_counts=(24, 16, 8)
    )
    config = dataclasses.replace(config, gripper=gripper)
    assert config.gripper.n_filaments == 48
    run = run_trial_case(config)
    assert_sound(run, limits)


@pytest.mark.parametrize("preset", PRESETS)
def test_filaments_starting_interpenetrated_with_the_object(preset, resolve_case, run_trial_case, limits):
    """The hub starts 80 mm lower: the straight filaments pass through the branches at t = 0."""
    config = resolve_case(preset, [])

    def sink(physics):
        physics.data.mocap_pos[0, 2] -= 0.08

    run = run_trial_case(config, prepare=sink)
    assert_sound(run, limits)


@pytest.mark.parametrize("preset", PRESETS)
def test_fast_lift(preset, resolve_case, run_trial_case, limits):
    """Lift at 1 m/s (20 times the default speed)."""
    config = resolve_case(preset, ["phases.lift_speed_m_s=1.0", "phases.lift_height_m=0.1"])
    run = run_trial_case(config)
    assert_sound(run, limits)


@pytest.mark.slow
@pytest.mark.parametrize("preset", ALL_PRESETS)
def test_sixty_second_hold(preset, resolve_case, run_trial_case, limits):
    """A 60 s hold: slow energy drift or creeping penetration would show here."""
    config = resolve_case(preset, ["phases.hold_time_s=60"])
    run = run_trial_case(config)
    assert_sound(run, limits)


@pytest.mark.parametrize("preset", ["fast", "balanced", "accurate", pytest.param(CANDIDATE, marks=pytest.mark.slow)])
def test_largest_timestep_the_preset_allows(preset, resolve_case, run_trial_case, limits):
    """The envelope's largest timestep for the preset's own filament, in the contact-rich trial."""
    config = resolve_case(preset, [])
    largest = stability.stable_timestep_s(config)
    if preset == CANDIDATE and largest < config.numerics.timestep_s:
        # the candidate's own step lies outside its stretch joint's map without armature, and says so
        assert any("stable envelope" in w for w in stability.envelope_warnings(config))
    else:
        assert largest >= config.numerics.timestep_s
    config = dataclasses.replace(
        config, numerics=dataclasses.replace(config.numerics, timestep_s=largest)
    )
    assert not stability.envelope_warnings(config)
    run = run_trial_case(config)
    assert_sound(run, limits)
