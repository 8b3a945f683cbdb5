"""Numerical stability: the measured envelope of stable numerics, and the checks against it.

The stability probe (task `probe/curl_in_air`, `suite.probe`) runs a gripper (no object) hanging from a
fixed hub: random joint perturbations, a pressure ramp to the configured pressure, a hold, all under the
runner's watchdog with an energy bound scaled to the gripper's own energy. `studies.stability_map` sweeps it
over Young's modulus x timestep x segments for every integrator with a small array that touches itself
(MAP_GRIPPER: three filaments 8.7 mm apart, every contact effect on, since filament contact halves the stable
timestep of stiff filaments compared with a lone rod); the boundary is recorded in ENVELOPE below, and a test
recomputes it from the stored map (results/stability/stability_map.csv). Coils tighter than the reference
need a further limit, dt c kappa^2 <= COIL_TIMESTEP_NUMBER, from the study's coil sweep. `envelope_warnings`
compares a resolved configuration against both before a run, and `stable_timestep_s` gives the largest
timestep they allow.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from entangle_bench.filament import MODAL_STRETCH_ARMATURE_RATIO, REFERENCE_PRESSURE_PA, FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import PRESETS, Numerics

#: The filament the stability map was measured with (the reference design).
REFERENCE_FILAMENT = FilamentParams()

#: Layout of the stability map: three filaments on a 10 mm circle (8.7 mm apart), close enough to
#: coil into each other, with every contact effect of the default Effects on.
MAP_GRIPPER = GripperParams(filament=REFERENCE_FILAMENT, ring_diameters_m=(0.01,), ring_counts=(3,))


# --------------------------------------------------------------------------------------------------
# The measured envelope

INTEGRATORS = ("euler", "implicitfast", "implicit", "rk4")
MAP_SEGMENTS = (8, 12, 16, 24, 40, 64, 96)
MAP_MODULI_PA = (0.05e6, 0.2e6, 1e6, 3e6, 10e6, 30e6)
MAP_TIMESTEPS_S = (0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3, 8e-3)

#: Largest timestep (s) at which the probe was stable, and every smaller one too (0: none down to
#: 0.25 ms), measured by `studies.stability_map` (results/stability/stability_map.csv;
#: MAP_GRIPPER, 0.6 s probes, each integrator with `base_numerics`): integrator -> segments -> one
#: value per modulus of MAP_MODULI_PA. 8 ms is the largest timestep measured, not a limit found. The
#: map holds the reference filament (L = 300 mm), so a configuration is looked up by its equivalent
#: segment count L_ref / ds and its equivalent modulus (same EI / (rho A)).
ENVELOPE: dict[str, dict[int, tuple[float, ...]]] = {
    "euler": {
        8: (0.008, 0.008, 0.008, 0.008, 0.008, 0.004),
        12: (0.008, 0.008, 0.008, 0.008, 0.004, 0.002),
        16: (0.008, 0.008, 0.008, 0.008, 0.004, 0.001),
        24: (0.008, 0.008, 0.008, 0.004, 0.001, 0.0005),
        40: (0.008, 0.004, 0.004, 0.002, 0.0005, 0),
        64: (0.004, 0.004, 0.002, 0.0005, 0.00025, 0),
        96: (0.004, 0.002, 0.001, 0.00025, 0, 0),
    },
    "implicitfast": {
        8: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        12: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        16: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        24: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        40: (0.002, 0.002, 0.008, 0.008, 0.008, 0.008),
        64: (0.001, 0.002, 0.004, 0.008, 0.008, 0.008),
        96: (0.002, 0.004, 0.008, 0.008, 0.008, 0.008),
    },
    "implicit": {
        8: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        12: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        16: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        24: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        40: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        64: (0.008, 0.004, 0.008, 0.008, 0.008, 0.008),
        96: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
    },
    "rk4": {
        8: (0.008, 0.008, 0.008, 0.008, 0.008, 0.008),
        12: (0.008, 0.008, 0.008, 0.008, 0.008, 0.002),
        16: (0.008, 0.008, 0.008, 0.008, 0.004, 0.002),
        24: (0.008, 0.008, 0.008, 0.008, 0.002, 0.0005),
        40: (0.008, 0.008, 0.008, 0.002, 0.0005, 0.00025),
        64: (0.008, 0.008, 0.004, 0.001, 0.00025, 0),
        96: (0.008, 0.008, 0.001, 0.0005, 0, 0),
    },
}


#: Numerics the map was measured with (only the timestep varied): those of the presets when it was
#: measured (euler: fast and balanced; implicitfast: accurate; implicit and rk4: balanced's with the
#: integrator swapped). A preset whose other numerics differ from these needs the map run again.
MAP_NUMERICS: dict[str, Numerics] = {
    "euler": Numerics(),
    "implicitfast": Numerics(
        integrator="implicitfast",
        solver="newton",
        iterations=100,
        tolerance=1e-8,
        twist_armature_scale=100.0,
    ),
    "implicit": Numerics(integrator="implicit"),
    "rk4": Numerics(integrator="rk4"),
}


#: The map of the clamp's stretch joint (`FilamentParams.stretch_at_clamp`, the grasp calibration candidate's
#: filament): the same probe with the candidate's hinge chain, stretch joint, rest twist, stiff elliptic contact
#: (2 ms time constant, impedance 0.99, friction 2) and impratio 10 (`scripts/stability_map.py --candidate`,
#: results/stability/candidate/stability_map.csv). Euler only, at 24-64 segments; timesteps 0.125-1 ms (a 2 ms
#: contact time constant needs dt <= 1 ms, so 1 ms is the largest measured, not a limit found); one value per
#: modulus of STRETCH_MAP_MODULI_PA (7 MPa added to bracket the candidate's 6.1 MPa equivalent). The stretch
#: joint's explicit Kelvin-Voigt damping is what costs the step: without it the probe at 40 segments, 10 MPa,
#: 0.25 ms is stable, with it alone unstable.
STRETCH_MAP_MODULI_PA = (0.05e6, 0.2e6, 1e6, 3e6, 7e6, 10e6, 30e6)
STRETCH_MAP_TIMESTEPS_S = (0.125e-3, 0.25e-3, 0.5e-3, 1e-3)
STRETCH_ENVELOPE: dict[str, dict[int, tuple[float, ...]]] = {
    "euler": {
        24: (0.001, 0.001, 0.001, 0.001, 0.000125, 0, 0),
        40: (0.001, 0.001, 0.001, 0.0005, 0.000125, 0, 0),
        64: (0.001, 0.001, 0.001, 0.0005, 0, 0.000125, 0),
    },
}


#: The same map with the stretch joint's armature at MODAL_STRETCH_ARMATURE_RATIO of the filament's mass
#: (`--candidate --set gripper.filament.stretch_armature_ratio=0.405`, results/stability/candidate_armature/):
#: the armature gives the joint the rod's first axial mode instead of one that moves the first segment alone,
#: and gives the step back (40 segments, 7 MPa: 0.5 ms against 0.125 ms).
ARMATURE_STRETCH_ENVELOPE: dict[str, dict[int, tuple[float, ...]]] = {
    "euler": {
        24: (0.001, 0.001, 0.001, 0.001, 0.0005, 0.0005, 0.000125),
        40: (0.001, 0.001, 0.001, 0.001, 0.0005, 0.0005, 0.000125),
        64: (0.001, 0.001, 0.001, 0.001, 0.00025, 0.00025, 0),
    },
}


class MeasuredMap(NamedTuple):
    """A stored stability table with its axes and what it maps."""

    table: dict[str, dict[int, tuple[float, ...]]]
    moduli_pa: tuple[float, ...]
    timesteps_s: tuple[float, ...]
    name: str


def envelope_of(filament: FilamentParams) -> MeasuredMap:
    """The measured map for `filament`: with a stretch joint at the clamp ARMATURE_STRETCH_ENVELOPE if its
    armature is at least the modal one (the map ran at 0.405, hence the 1e-3 tolerance), else STRETCH_ENVELOPE
    (measured without armature); without one ENVELOPE."""
    if filament.stretch_at_clamp:
        if filament.stretch_armature_ratio >= MODAL_STRETCH_ARMATURE_RATIO * (1 - 1e-3):
            return MeasuredMap(ARMATURE_STRETCH_ENVELOPE, STRETCH_MAP_MODULI_PA, STRETCH_MAP_TIMESTEPS_S,
                               "stability map of the clamp's stretch joint with its modal armature")
        return MeasuredMap(STRETCH_ENVELOPE, STRETCH_MAP_MODULI_PA, STRETCH_MAP_TIMESTEPS_S,
                           "stability map of the clamp's stretch joint without armature")
    return MeasuredMap(ENVELOPE, MAP_MODULI_PA, MAP_TIMESTEPS_S, "stability map")


def base_numerics(integrator: str) -> Numerics:
    """Numerics the map used for `integrator` (timestep: the default 2 ms, varied by the map)."""
    return MAP_NUMERICS[integrator]


def equivalent_segments(filament: FilamentParams) -> float:
    """Segments the reference filament would need for the same segment length."""
    return REFERENCE_FILAMENT.length_m / filament.segment_length_m


def equivalent_modulus_pa(filament: FilamentParams) -> float:
    """Modulus giving the reference filament the same bending wave speed^2 EI / (rho A), Pa."""
    ref = REFERENCE_FILAMENT
    per_pa = ref.bending_stiffness_nm2 / ref.youngs_modulus_pa / ref.linear_density_kg_m
    return filament.bending_stiffness_nm2 / filament.linear_density_kg_m / per_pa


def max_stable_timestep_s(
    integrator: str,
    n_segments: float,
    modulus_pa: float,
    table: dict[str, dict[int, tuple[float, ...]]] | None = None,
    moduli_pa: tuple[float, ...] = MAP_MODULI_PA,
) -> float | None:
    """Largest measured stable timestep for reference-equivalent segments and modulus, s, in `table`
    (ENVELOPE by default) whose values are per modulus of `moduli_pa`.

    Conservative lookup: the smallest value of the measured points around the requested one (the
    segment rows and moduli just below and just above it; stability is not monotone in either: soft
    fine filaments are the least stable for implicit integrators). None outside the map.
    """
    by_n = (ENVELOPE if table is None else table).get(integrator)
    if not by_n:
        return None
    rows = sorted(by_n)
    if n_segments > rows[-1] * (1 + 1e-9):
        return None
    near_rows = _bracket(rows, n_segments)
    moduli = moduli_pa[: len(by_n[rows[0]])]
    if not moduli[0] * (1 - 1e-9) <= modulus_pa <= moduli[-1] * (1 + 1e-9):
        return None
    near_moduli = _bracket(list(moduli), modulus_pa)
    return min(by_n[n][moduli.index(e)] for n in near_rows for e in near_moduli)


def _bracket(grid: list[float], value: float) -> list[float]:
    """The grid points just below and just above `value` (one if it lies on or beyond the grid)."""
    below = [g for g in grid if g <= value * (1 + 1e-9)]
    above = [g for g in grid if g >= value * (1 - 1e-9)]
    return sorted(set(below[-1:] + above[:1]))


def preset_envelopes(
    table: dict[str, dict[int, tuple[float, ...]]] | None = None,
) -> dict[str, dict[str, object]]:
    """Envelope of every preset for the reference filament and coil.

    Per preset: its settings, the largest stable timestep at E = 1 MPa, and the moduli and finest
    segmentation stable at its own timestep (rod table and coil limit).
    """
    table = ENVELOPE if table is None else table
    ref = REFERENCE_FILAMENT
    kappa = ref.curvature_per_m(REFERENCE_PRESSURE_PA)
    out: dict[str, dict[str, object]] = {}
    rate_per_sqrt_pa = bending_wave_speed_m2_s(ref) * kappa**2 / math.sqrt(ref.youngs_modulus_pa)

    def limit(integrator: str, segments: float, modulus: float) -> float:
        rod = max_stable_timestep_s(integrator, segments, modulus, table) or 0.0
        return min(rod, COIL_TIMESTEP_NUMBER / (rate_per_sqrt_pa * math.sqrt(modulus)))

    for name, preset in PRESETS.items():
        num, n = preset.numerics, preset.n_segments
        moduli = [e for e in MAP_MODULI_PA if limit(num.integrator, n, e) >= num.timestep_s]
        finest = [
            m
            for m in table.get(num.integrator, {})
            if limit(num.integrator, m, 1e6) >= num.timestep_s
        ]
        out[name] = {
            "integrator": num.integrator,
            "n_segments": n,
            "timestep_s": num.timestep_s,
            "max_timestep_s": limit(num.integrator, n, 1e6),
            "modulus_range": (
                f"{min(moduli) / 1e6:g} to {max(moduli) / 1e6:g}" if moduli else "none measured"
            ),
            "max_modulus_pa": max(moduli) if moduli else 0.0,
            "max_segments": max(finest) if finest else 0,
        }
    return out


#: Largest rest rotation per segment kappa * ds, rad. Beyond it the discrete coil curls unphysically
#: fast (default top-drape trial, balanced preset: largest body speed 0.9 m/s at 2 rad, 2.3 m/s at
#: 2.5 rad, 6.7 m/s at 3 rad, against 0.55 m/s unactuated-scale motion), and past pi the ball-joint
#: spring wraps.
MAX_TURN_PER_SEGMENT_RAD = 2.0

#: Coil limit: dt * c * kappa^2 at most this (c = sqrt(EI / (rho A))). A tight coil curls, and its
#: turns collide, at the bending-wave rate of its own curvature, which the rod map (reference 12.5
#: mm coil) does not cover. Measured by `studies.stability_map` (coil sweep,
#: results/stability/coil_map.csv: one filament with and without contact, coil radii 2.1-12.5 mm, E
#: 1-10 MPa, euler and implicitfast); the smallest dt c kappa^2 at which a limit was found is
#: printed by `scripts/stability_map.py` and quoted in the README (0.6 lies below all of them).
COIL_TIMESTEP_NUMBER = 0.6
MAP_COIL_RADII_M = (0.0125, 0.008, 0.0058, 0.004, 0.0028, 0.0021)
MAP_COIL_MODULI_PA = (1e6, 3e6, 10e6)
MAP_COIL_INTEGRATORS = ("euler", "implicitfast")

#: Tightest coil the actuation law is used for, in filament radii (Becker et al. 2022 design range).
MIN_COIL_RADIUS_RATIO = 3.0

#: Integrators whose joint damping is explicit (its stability limit falls as the damping time
#: grows).
EXPLICIT_DAMPING = ("euler", "rk4")


def envelope_warnings(config: object) -> list[str]:
    """Warnings for a resolved configuration outside the measured stability envelope.

    `config` is anything with `.gripper` and `.numerics` (and optionally `.effects`).

    Checks the timestep against ENVELOPE for the configuration's integrator, equivalent segments and
    modulus, and against the coil limit (COIL_TIMESTEP_NUMBER) of the actuated curvature; the point
    against the range the map covers; the numerics the map did not vary (twist armature, damping
    time) in their destabilizing direction; and the actuation: rest rotation per segment above
    MAX_TURN_PER_SEGMENT_RAD, coil radius below MIN_COIL_RADIUS_RATIO filament radii.
    """
    gripper, num = config.gripper, config.numerics
    fil = gripper.filament
    out = []
    n_eq, e_eq = equivalent_segments(fil), equivalent_modulus_pa(fil)
    where = (
        f"{fil.n_segments} segments of {fil.segment_length_m * 1e3:.3g} mm, "
        f"E = {e_eq / 1e6:.3g} MPa"
    )
    if not (math.isclose(n_eq, fil.n_segments) and math.isclose(e_eq, fil.youngs_modulus_pa)):
        where += " (reference-filament equivalent)"
    table, moduli, timesteps, which = envelope_of(fil)
    dt_max = max_stable_timestep_s(num.integrator, n_eq, e_eq, table, moduli)
    if num.integrator not in table:
        out.append(
            f"the {num.integrator} integrator is not in the measured {which} "
            f"(mapped: {', '.join(table)}); stability is unknown"
        )
    elif dt_max is None:
        out.append(
            f"{where} with the {num.integrator} integrator lies outside the measured {which} "
            f"(up to {max(table[num.integrator])} reference segments, "
            f"E up to {max(moduli) / 1e6:g} MPa); "
            "stability is unknown"
        )
    elif num.timestep_s > dt_max * (1 + 1e-9):
        limit = f"{dt_max * 1e3:g} ms" if dt_max > 0 else f"none down to {min(timesteps):g} s"
        out.append(
            f"numerics.timestep_s = {num.timestep_s:g} s exceeds the stable envelope ({which}) of the "
            f"{num.integrator} integrator for {where} (largest stable timestep measured: {limit})"
        )
    coil = coil_timestep_limit_s(config)
    if num.timestep_s > coil * (1 + 1e-9):
        out.append(
            f"numerics.timestep_s = {num.timestep_s:g} s is too long for the actuated coil: "
            f"dt c kappa^2 = {num.timestep_s * coil_rate_per_s(config):.3g} > "
            f"{COIL_TIMESTEP_NUMBER:g} (c = sqrt(EI / (rho A))): the coil curls faster than the "
            f"timestep resolves; use at most {coil * 1e3:.3g} ms"
        )
    base = MAP_NUMERICS.get(num.integrator)
    if base is not None and num.twist_armature_scale < base.twist_armature_scale:
        out.append(
            f"numerics.twist_armature_scale = {num.twist_armature_scale:g} is below the "
            f"{base.twist_armature_scale:g} the stability map used for {num.integrator}; "
            "torsional waves are faster and the envelope may not hold"
        )
    if (
        num.integrator in EXPLICIT_DAMPING
        and not num.euler_implicit_damping
        and (fil.damping_time_s > REFERENCE_FILAMENT.damping_time_s)
    ):
        out.append(
            f"filament.damping_time_s = {fil.damping_time_s:g} s is above the "
            f"{REFERENCE_FILAMENT.damping_time_s:g} s of the stability map; explicit joint damping "
            f"({num.integrator}) then needs a smaller timestep than the envelope's"
        )
    kappa = fil.curvature_per_m(gripper.pressure_pa)
    turn = kappa * fil.segment_length_m
    if turn > MAX_TURN_PER_SEGMENT_RAD * (1 + 1e-9):
        needed = math.ceil(kappa * fil.length_m / MAX_TURN_PER_SEGMENT_RAD)
        out.append(
            f"the actuated coil is under-resolved: {turn:.3g} rad of rest rotation per segment "
            f"(at most {MAX_TURN_PER_SEGMENT_RAD:g}); use at least {needed} segments"
        )
    if kappa > 0 and 1.0 / kappa < MIN_COIL_RADIUS_RATIO * fil.outer_radius_m:
        out.append(
            f"the actuated coil radius {1e3 / kappa:.3g} mm is below {MIN_COIL_RADIUS_RATIO:g} "
            f"filament radii ({MIN_COIL_RADIUS_RATIO * fil.outer_radius_m * 1e3:.3g} mm), "
            "tighter than the actuation law is used for"
        )
    return out


def stable_timestep_s(config: object) -> float | None:
    """Largest timestep of the envelope for a configuration (rod map and coil limit), s.

    None when the configuration lies outside the rod map.
    """
    fil = config.gripper.filament
    table, moduli, _, _ = envelope_of(fil)
    rod = max_stable_timestep_s(
        config.numerics.integrator, equivalent_segments(fil), equivalent_modulus_pa(fil), table, moduli
    )
    return None if rod is None else min(rod, coil_timestep_limit_s(config))


def bending_wave_speed_m2_s(filament: FilamentParams) -> float:
    """c = sqrt(EI / (rho A)), m^2/s: a bending wave of wavenumber k has angular frequency c k^2."""
    return math.sqrt(filament.bending_stiffness_nm2 / filament.linear_density_kg_m)


def coil_rate_per_s(config: object) -> float:
    """c kappa^2, 1/s: angular frequency of a bending wave of the actuated coil's wavenumber."""
    fil = config.gripper.filament
    kappa = fil.curvature_per_m(config.gripper.pressure_pa)
    return bending_wave_speed_m2_s(fil) * kappa**2


def coil_timestep_limit_s(config: object) -> float:
    """COIL_TIMESTEP_NUMBER / (c kappa^2), s (infinite when not actuated)."""
    rate = coil_rate_per_s(config)
    return COIL_TIMESTEP_NUMBER / rate if rate > 0 else math.inf
