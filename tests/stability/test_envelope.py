"""The stability envelope: table lookups, warnings, and the table re-measured against the engine."""

import dataclasses
from pathlib import Path

import pandas as pd
import pytest

from entangle_bench import effects as fx
from entangle_bench import stability
from entangle_bench.calibration import candidate_overrides
from entangle_bench.errors import ParameterError
from entangle_bench.filament import FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import PRESETS, get_preset
from entangle_bench.studies.stability_map import boundary, check_overrides, probe, probe_config
from entangle_bench.suite import TASKS, resolve_config
from entangle_bench.suite.probe import ProbeConfig

STORED_MAP = Path(__file__).resolve().parents[2] / "results" / "stability"


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_every_task_at_every_preset_is_inside_its_envelope(preset):
    for task in TASKS.names():
        assert stability.envelope_warnings(resolve_config(task, preset)) == [], task


def test_envelope_table_is_the_stored_map():
    """ENVELOPE is what the stored stability map gives, and the coil limit lies below every measured limit."""
    assert boundary(pd.read_csv(STORED_MAP / "stability_map.csv")) == stability.ENVELOPE
    coils = pd.read_csv(STORED_MAP / "coil_map.csv")
    largest = coils["largest_stable_timestep_s"]
    bounded = coils[(largest > 0) & (largest < max(stability.MAP_TIMESTEPS_S))]
    assert len(bounded) > 0
    assert bounded["stable_number"].min() >= stability.COIL_TIMESTEP_NUMBER


def test_stretch_envelope_table_is_the_stored_map():
    """STRETCH_ENVELOPE is what the stored map of the stretch joint (`--candidate`) gives, and it is what a
    filament with the stretch joint is looked up in: the calibration candidate's 0.25 ms lies outside it."""
    frame = pd.read_csv(STORED_MAP / "candidate" / "stability_map.csv")
    assert sorted(frame["youngs_modulus_pa"].unique()) == list(stability.STRETCH_MAP_MODULI_PA)
    assert boundary(frame) == stability.STRETCH_ENVELOPE
    stretched = resolve_config("eight_branch_tree", None, candidate_overrides())
    assert stretched.gripper.filament.stretch_at_clamp
    assert stability.stable_timestep_s(stretched) == 0.125e-3
    assert any("stretch joint" in w and "0.125 ms" in w for w in stability.envelope_warnings(stretched))
    plain = dataclasses.replace(stretched, gripper=dataclasses.replace(
        stretched.gripper, filament=dataclasses.replace(stretched.gripper.filament, stretch_at_clamp=False)))
    assert stability.stable_timestep_s(plain) > 0.25e-3


def test_armature_envelope_table_is_the_stored_map():
    """ARMATURE_STRETCH_ENVELOPE is the stored map with the stretch joint's modal armature, a stretch joint
    with that armature is looked up in it (the candidate's filament: 0.5 ms, not 0.125 ms; the coil limit then
    binds), and the map holds a longer step than the one without armature in no column less."""
    frame = pd.read_csv(STORED_MAP / "candidate_armature" / "stability_map.csv")
    assert boundary(frame) == stability.ARMATURE_STRETCH_ENVELOPE
    for n, row in stability.ARMATURE_STRETCH_ENVELOPE["euler"].items():
        assert all(a >= b for a, b in zip(row, stability.STRETCH_ENVELOPE["euler"][n]))
    config = resolve_config("eight_branch_tree", None, [*candidate_overrides(), "numerics.timestep_s=0.0005",
                                                       "gripper.filament.stretch_armature_ratio=0.405"])
    fil = config.gripper.filament
    table, moduli, _, name = stability.envelope_of(fil)
    assert table is stability.ARMATURE_STRETCH_ENVELOPE and "modal armature" in name
    assert stability.max_stable_timestep_s("euler", stability.equivalent_segments(fil),
                                           stability.equivalent_modulus_pa(fil), table, moduli) == 0.5e-3
    warnings = stability.envelope_warnings(config)
    assert not any("stable envelope" in w for w in warnings)
    assert stability.stable_timestep_s(config) == stability.coil_timestep_limit_s(config) < 0.5e-3


def test_every_preset_timestep_is_inside_the_measured_table():
    for name, summary in stability.preset_envelopes().items():
        assert summary["max_timestep_s"] >= summary["timestep_s"], name
        assert summary["max_modulus_pa"] >= 1e6 and summary["max_segments"] >= summary["n_segments"]


def test_lookup_is_conservative_between_measured_points():
    """Between grid points the least stable of the surrounding measured points decides."""
    table = {"euler": {12: (8e-3, 4e-3, 2e-3), 24: (4e-3, 2e-3, 1e-3)}}
    moduli = stability.MAP_MODULI_PA[:3]
    assert stability.max_stable_timestep_s("euler", 12, moduli[1], table) == 4e-3
    assert stability.max_stable_timestep_s("euler", 13, moduli[1], table) == 2e-3
    assert stability.max_stable_timestep_s("euler", 12, moduli[1] * 1.01, table) == 2e-3
    assert stability.max_stable_timestep_s("euler", 4, moduli[0], table) == 8e-3
    assert stability.max_stable_timestep_s("euler", 25, moduli[0], table) is None
    assert stability.max_stable_timestep_s("euler", 12, moduli[2] * 1.01, table) is None
    assert stability.max_stable_timestep_s("euler", 12, moduli[0] * 0.99, table) is None
    assert stability.max_stable_timestep_s("rk4", 12, moduli[0], table) is None
    # Softer can be less stable (implicit integrators, fine soft filaments): both sides count.
    soft = {"implicitfast": {12: (1e-3, 4e-3, 8e-3)}}
    assert stability.max_stable_timestep_s("implicitfast", 12, moduli[0] * 2, soft) == 1e-3


def test_equivalent_filament_maps_geometry_onto_the_reference():
    """Half the length at the same segment length is the same row; EI/(rho A) fixes the modulus."""
    ref = stability.REFERENCE_FILAMENT
    short = FilamentParams(length_m=ref.length_m / 2, n_segments=ref.n_segments // 2)
    assert stability.equivalent_segments(short) == pytest.approx(ref.n_segments)
    denser = FilamentParams(density_kg_m3=2 * ref.density_kg_m3, youngs_modulus_pa=2e6)
    assert stability.equivalent_modulus_pa(denser) == pytest.approx(1e6)


def warnings_for(preset, overrides):
    return stability.envelope_warnings(resolve_config("eight_branch_tree", preset, overrides))


def test_out_of_envelope_settings_are_named():
    assert any(
        "timestep" in w and "euler" in w
        for w in warnings_for(
            "fast", ["gripper.filament.youngs_modulus_pa=3e7", "gripper.filament.n_segments=64"]
        )
    )
    assert any(
        "outside the measured stability map" in w
        for w in warnings_for("fast", ["gripper.filament.n_segments=400"])
    )
    assert any(
        "twist_armature_scale" in w
        for w in warnings_for("fast", ["numerics.twist_armature_scale=10"])
    )
    assert any(
        "damping_time_s" in w for w in warnings_for("fast", ["gripper.filament.damping_time_s=0.1"])
    )
    under = warnings_for("balanced", ["gripper.pressure_pa=5e5"])
    assert any("under-resolved" in w and "use at least" in w for w in under)
    assert any(
        "below 3 filament radii" in w
        for w in warnings_for("balanced", ["gripper.pressure_pa=1.5e6"])
    )
    stiff_coil = warnings_for(
        "fast",
        [
            "gripper.filament.youngs_modulus_pa=1e7",
            "gripper.pressure_pa=1.72e6",
            "numerics.timestep_s=0.004",
        ],
    )
    assert any("too long for the actuated coil" in w for w in stiff_coil)
    # An integrator the map has not measured is named, not looked up (it raised KeyError before).
    assert any(
        "discrete integrator is not in the measured stability map" in w
        for w in warnings_for("balanced", ["numerics.integrator=discrete"])
    )
    # Implicit integration keeps stiff fine filaments inside the envelope.
    assert warnings_for("accurate", ["gripper.filament.youngs_modulus_pa=1e7"]) == []


def test_table_boundary_remeasured():
    """Euler, 24 segments, E = 10 MPa: stable at the table's timestep, unstable at twice it."""
    limit = stability.max_stable_timestep_s("euler", 24, 10e6)
    assert 0 < limit < get_preset("fast").numerics.timestep_s
    for seed in (3, 4):
        assert probe(probe_config("euler", 24, 10e6, limit), seed=seed).stable
    assert not probe(probe_config("euler", 24, 10e6, 2 * limit), seed=3).stable


def test_coil_limit_catches_a_tight_stiff_coil():
    """Hypothesis found it: implicitfast, 8 ms, E = 3.2 MPa, 5.8 mm coil touching itself.

    Inside the rod table (which holds the 12.5 mm coil) but unstable; the coil limit warns and its
    timestep is stable.
    """
    ref = stability.REFERENCE_FILAMENT
    fil = dataclasses.replace(ref, youngs_modulus_pa=3.16e6, n_segments=26)
    gripper = GripperParams(
        filament=fil, ring_diameters_m=(0.0,), ring_counts=(1,), pressure_pa=1.166e6
    )
    numerics = dataclasses.replace(stability.base_numerics("implicitfast"), timestep_s=8e-3)
    config = ProbeConfig(gripper=gripper, numerics=numerics, duration_s=0.6)
    assert stability.max_stable_timestep_s("implicitfast", 26, 3.16e6) == 8e-3
    assert any("too long for the actuated coil" in w for w in stability.envelope_warnings(config))
    assert not probe(config).stable
    limit = stability.stable_timestep_s(config)
    assert limit < 2e-3
    safe = dataclasses.replace(config, numerics=dataclasses.replace(numerics, timestep_s=limit))
    assert stability.envelope_warnings(safe) == []
    assert all(probe(safe, seed=s).stable for s in (0, 1))
    # Without contact the same coil is unstable at 8 ms too: the limit holds for the rest shape.
    apart = dataclasses.replace(config, effects=fx.NO_CONTACT)
    assert stability.stable_timestep_s(apart) == limit
    assert not all(probe(apart, seed=s).stable for s in (0, 1, 2))


def test_presets_use_the_numerics_the_map_was_measured_with():
    """A preset whose solver settings change needs the stability map (`scripts/stability_map.py`) run again."""
    for name, preset in PRESETS.items():
        measured = stability.base_numerics(preset.numerics.integrator)
        same_step = dataclasses.replace(preset.numerics, timestep_s=measured.timestep_s)
        assert same_step == measured, name


def test_map_overrides_reach_every_probe_and_spare_the_swept_fields():
    """`--set` on the map: applied on top of each point's own settings; a swept field is refused by name."""
    config = probe_config("euler", 40, 3e6, 2.5e-4, overrides=["contact.timeconst_s=0.002",
                                                               "gripper.filament.joints=hinges"])
    assert (config.contact.timeconst_s, config.gripper.filament.joints) == (0.002, "hinges")
    assert (config.numerics.timestep_s, config.gripper.filament.n_segments) == (2.5e-4, 40)
    assert config.gripper.filament.youngs_modulus_pa == 3e6
    with pytest.raises(ParameterError, match="numerics.timestep_s is swept by the map"):
        check_overrides(["numerics.timestep_s=0.001"])
    with pytest.raises(ParameterError, match="contact.bogus"):
        check_overrides(["contact.bogus=1"])
