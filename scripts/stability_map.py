"""Stability map (`entangle_bench.studies.stability_map`): run or replot it and print the envelope tables.

Usage: python scripts/stability_map.py [--out results/stability] [--full] [--duration 0.6] [--set a.b=v ...]
       python scripts/stability_map.py --candidate --out results/stability/candidate --integrators euler
       python scripts/stability_map.py --from-csv results/stability   (replot, summarize)

Writes stability_map.{csv,png} and coil_map.{csv,png}, prints the ENVELOPE table kept in
`entangle_bench.stability`, every preset's envelope and the coil sweep. About 6 minutes on one core.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

import mujoco
import pandas as pd

from entangle_bench import stability
from entangle_bench.calibration import candidate_overrides
from entangle_bench.errors import EntangleBenchError
from entangle_bench.results import atomic_write_csv
from entangle_bench.studies import stability_map


def candidate_map_overrides() -> list[str]:
    """The calibration candidate's overrides a map can take: joints, clamp, twist, contact, cone and solver
    settings; not its geometry (the map's modulus axis is the reference filament's), phases or swept fields.
    Its impratio applies in every phase of the probe (the candidate's applies from the lift on)."""
    keep = ("gripper.filament.joints", "gripper.filament.stretch_at_clamp", "gripper.filament.twist_ratio",
            "contact.", "effects.", "numerics.impratio=")
    return [o for o in candidate_overrides() if o.startswith(keep)]


def main(argv: list[str] | None = None) -> int:
    """Run the sweep, write CSV and PNG, print the boundary table and preset envelopes."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/stability"))
    parser.add_argument("--full", action="store_true", help="run every point (no inferred points)")
    parser.add_argument(
        "--duration", type=float, default=stability_map.MAP_DURATION_S, help="simulated seconds per probe"
    )
    parser.add_argument("--integrators", nargs="+", default=list(stability.INTEGRATORS))
    parser.add_argument("--segments", nargs="+", type=int, default=list(stability.MAP_SEGMENTS))
    parser.add_argument("--moduli", nargs="+", type=float, default=list(stability.MAP_MODULI_PA))
    parser.add_argument(
        "--timesteps", nargs="+", type=float, default=list(stability.MAP_TIMESTEPS_S)
    )
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE",
                        help="override a probe field on every point (not a swept one), e.g. contact.timeconst_s=0.002")
    parser.add_argument("--candidate", action="store_true",
                        help="map the grasp calibration candidate's joints, contact and numerics (its overrides "
                             "other than the swept fields, geometry and phases), then --set")
    parser.add_argument(
        "--from-csv",
        type=Path,
        default=None,
        help="replot and summarize the CSVs of an earlier run in this folder instead of sweeping",
    )
    args = parser.parse_args(argv)
    overrides = (candidate_map_overrides() if args.candidate else []) + args.overrides
    try:
        stability_map.check_overrides(overrides)
    except EntangleBenchError as exc:
        parser.error(str(exc))
    if overrides:
        print("overrides: " + " ".join(overrides))
    if args.from_csv is not None:
        frame = pd.read_csv(args.from_csv / "stability_map.csv")
        coils = pd.read_csv(args.from_csv / "coil_map.csv")
    else:
        # Unstable probes are the point here: keep MuJoCo from printing (and logging) their warnings.
        mujoco.set_mju_user_warning(lambda text: None)
        frame = stability_map.sweep(
            args.integrators, args.segments, args.moduli, args.timesteps, args.duration, args.full, overrides
        )
        atomic_write_csv(frame, args.out / "stability_map.csv")
        coils = stability_map.coil_sweep(args.timesteps, args.duration, overrides)
        atomic_write_csv(coils, args.out / "coil_map.csv")
    stability_map.write_outputs(frame, coils, args.out)
    table = stability_map.boundary(frame)
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
        f"probes run: {int(frame['measured'].sum())}, wall {frame['wall_time_s'].sum():.0f} s"
    )
    print("ENVELOPE = {")
    for integrator, by_n in table.items():
        print(f'    "{integrator}": {{')
        for n, limits in by_n.items():
            print(f"        {n}: ({', '.join(f'{v:g}' for v in limits)}),")
        print("    },")
    print("}")
    if sorted(frame["youngs_modulus_pa"].unique()) != list(stability.MAP_MODULI_PA) or overrides:
        print("preset envelopes: not printed (the presets are judged on the default map's moduli and settings)")
    else:
        print(
            "| preset | integrator | segments | timestep (ms) "
            "| largest stable timestep at E = 1 MPa (ms) "
            "| E range stable at the preset timestep (MPa) | largest segments at the preset timestep |"
        )
        print("|---|---|---|---|---|---|---|")
        for name, summary in stability.preset_envelopes(table).items():
            print(
                f"| {name} | {summary['integrator']} | {summary['n_segments']} | "
                f"{summary['timestep_s'] * 1e3:g} | {summary['max_timestep_s'] * 1e3:g} | "
                f"{summary['modulus_range']} | {summary['max_segments']} |"
            )
    print(
        "coil sweep: largest stable timestep x c kappa^2 (envelope limit "
        f"{stability.COIL_TIMESTEP_NUMBER:g})"
    )
    print(
        "| contact | integrator | E (MPa) | coil radius (mm) | segments | largest stable dt (ms) | "
        "dt c kappa^2 |"
    )
    print("|---|---|---|---|---|---|---|")
    for _, row in coils.iterrows():
        print(
            f"| {'all' if row['contact'] else 'none'} | "
            f"{row['integrator']} | {row['youngs_modulus_pa'] / 1e6:g} | "
            f"{row['coil_radius_m'] * 1e3:g} | {row['n_segments']} | "
            f"{row['largest_stable_timestep_s'] * 1e3:g} | {row['stable_number']:.2f} |"
        )
    largest = coils["largest_stable_timestep_s"]
    bounded = coils[(largest > 0) & (largest < max(args.timesteps))]
    none = coils[largest == 0]
    print(
        f"smallest dt c kappa^2 where a limit was found: {bounded['stable_number'].min():.2f}; "
        f"no stable timestep down to {min(args.timesteps) * 1e3:g} ms at "
        + (
            ", ".join(
                f"{r.integrator} E = {r.youngs_modulus_pa / 1e6:g} MPa "
                f"R = {r.coil_radius_m * 1e3:g} mm "
                f"(limit asks {stability.COIL_TIMESTEP_NUMBER / r.coil_rate_per_s * 1e3:.2g} ms)"
                for r in none.itertuples()
            )
            or "no point"
        )
        + f"; coil sweep wall {coils['wall_time_s'].sum():.0f} s"
    )
    print(f"csv and png: {args.out}/stability_map.*, {args.out}/coil_map.*")
    return 0


if __name__ == "__main__":
    sys.exit(main())
