"""Stability map: Young's modulus x timestep x segments for every integrator, plus tight coils.

Usage: python scripts/stability_map.py [--out results/stability] [--full] [--duration 0.6]
       python scripts/stability_map.py --from-csv results/stability   (replot, summarize)

Rod map: each point is one `entangle_bench.stability.probe` of `stability.MAP_GRIPPER`: three
reference filaments (300 mm, r = 0.7 mm) 8.7 mm apart, every contact effect on, hanging in air from
a fixed hub, every joint perturbed by 0.05 rad, the pressure ramped in 0.3 s to the reference
172 kPa, held to `--duration`; the law's calibration is scaled with E so that every modulus curls to
the same reference 12.5 mm coil. The probe runs under the runtime watchdog (NaN/Inf, MuJoCo
warnings, energy above the actuation work + 10 %, speed above 10 m/s). Each integrator runs with
`stability.MAP_NUMERICS`, only the timestep and segments changed. By default each (integrator,
segments, modulus) column is scanned from the largest timestep down and stops at the first stable
one: smaller timesteps are then marked stable without running ("inferred"); `--full` runs every
point (a full run of euler and rk4 at 24 and 64 segments found no column where a stable timestep
had an unstable smaller one).

Coil sweep: one filament, with every contact on and with none, curling to coils of 2.1-12.5 mm
(E 1-10 MPa, euler and implicitfast): the largest timestep stable for two seeds, against the coil
rate c kappa^2.

Writes stability_map.{csv,png} and coil_map.{csv,png}, prints the ENVELOPE table kept in
`entangle_bench.stability`, every preset's envelope and the coil sweep. About 6 minutes on one core.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import platform
import sys
from pathlib import Path

import matplotlib
import mujoco

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.ticker as ticker
import numpy as np
import pandas as pd
from tqdm import tqdm

from entangle_bench import effects as fx
from entangle_bench import stability
from entangle_bench.atomic import atomic_savefig
from entangle_bench.filament import REFERENCE_COIL_RADIUS_M, FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import PRESETS
from entangle_bench.results import atomic_write_csv
from entangle_bench.scene import SceneConfig


def probe_config(
    integrator: str, n_segments: int, modulus_pa: float, timestep_s: float
) -> SceneConfig:
    """The map's filament array with the map's numerics for `integrator`."""
    numerics = dataclasses.replace(
        stability.base_numerics(integrator), timestep_s=timestep_s, integrator=integrator
    )
    reference = stability.REFERENCE_FILAMENT
    filament = FilamentParams(
        youngs_modulus_pa=modulus_pa,
        n_segments=n_segments,
        curvature_calibration=reference.calibration * modulus_pa / reference.youngs_modulus_pa,
    )
    gripper = dataclasses.replace(stability.MAP_GRIPPER, filament=filament)
    return SceneConfig(gripper=gripper, numerics=numerics)


def coil_config(
    integrator: str, radius_m: float, modulus_pa: float, timestep_s: float, contact: bool
) -> SceneConfig:
    """One reference filament curling to a coil of `radius_m` (m), every contact on or none.

    Segments: at most MAX_TURN_PER_SEGMENT_RAD of rest rotation each, at least 16.
    """
    reference = stability.REFERENCE_FILAMENT
    n = max(16, math.ceil(reference.length_m / radius_m / stability.MAX_TURN_PER_SEGMENT_RAD))
    scale = modulus_pa / reference.youngs_modulus_pa * REFERENCE_COIL_RADIUS_M / radius_m
    filament = FilamentParams(
        youngs_modulus_pa=modulus_pa,
        n_segments=n,
        curvature_calibration=reference.calibration * scale,
    )
    gripper = GripperParams(filament=filament, ring_diameters_m=(0.0,), ring_counts=(1,))
    numerics = dataclasses.replace(stability.base_numerics(integrator), timestep_s=timestep_s)
    effects = fx.Effects() if contact else fx.NO_CONTACT
    return SceneConfig(gripper=gripper, effects=effects, numerics=numerics)


def coil_sweep(args: argparse.Namespace) -> pd.DataFrame:
    """Largest stable timestep (two seeds) per contact, integrator, modulus and coil radius."""
    columns = [
        (c, i, e, r)
        for c in (True, False)
        for i in stability.MAP_COIL_INTEGRATORS
        for e in stability.MAP_COIL_MODULI_PA
        for r in stability.MAP_COIL_RADII_M
    ]
    rows = []
    for contact, integrator, modulus, radius in tqdm(
        columns, desc="coil sweep", unit="point", file=sys.stderr
    ):
        largest, first_unstable, wall = 0.0, float("nan"), 0.0
        for dt in sorted(args.timesteps, reverse=True):
            config = coil_config(integrator, radius, modulus, dt, contact)
            results = [stability.probe(config, duration_s=args.duration, seed=s) for s in (0, 1)]
            wall += sum(r.wall_time_s for r in results)
            if all(r.stable for r in results):
                largest = dt
                break
            first_unstable = dt
        rate = stability.coil_rate_per_s(config)
        rows.append(
            {
                "contact": contact,
                "integrator": integrator,
                "youngs_modulus_pa": modulus,
                "coil_radius_m": radius,
                "n_segments": config.gripper.filament.n_segments,
                "coil_rate_per_s": rate,
                "largest_stable_timestep_s": largest,
                "smallest_unstable_timestep_s": first_unstable,
                "stable_number": largest * rate,
                "wall_time_s": wall,
            }
        )
    return pd.DataFrame(rows)


def plot_coil(frame: pd.DataFrame, path: Path) -> None:
    """Largest stable timestep against the coil rate c kappa^2, with the envelope's coil limit."""
    fig, axes = plt.subplots(1, 2, figsize=(10.0, 4.2), sharex=True, sharey=True)
    rates = np.geomspace(frame["coil_rate_per_s"].min() / 1.5, frame["coil_rate_per_s"].max() * 1.5)
    for ax, contact in zip(axes, (True, False)):
        cell = frame[frame["contact"] == contact]
        for (integrator, modulus), part in cell.groupby(["integrator", "youngs_modulus_pa"]):
            color = {1e6: "tab:blue", 3e6: "tab:orange", 10e6: "tab:green"}.get(modulus, "gray")
            euler = integrator == "euler"
            ax.scatter(
                part["coil_rate_per_s"],
                part["largest_stable_timestep_s"] * 1e3,
                marker="o" if euler else "s",
                s=70 if euler else 22,
                facecolors="none" if euler else color,
                edgecolors=color,
                label=f"{integrator}, E = {modulus / 1e6:g} MPa",
            )
        ax.plot(
            rates,
            stability.COIL_TIMESTEP_NUMBER / rates * 1e3,
            "k--",
            label=f"envelope: dt c kappa^2 = {stability.COIL_TIMESTEP_NUMBER:g}",
        )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("coil rate c kappa^2 (1/s)")
        ax.set_title(
            f"one filament, {'every contact on' if contact else 'no contact'}", fontsize=10
        )
    axes[0].set_ylabel("largest stable timestep (ms)")
    axes[0].legend(fontsize=7)
    fig.suptitle("Tight coils: coil radius 2.1-12.5 mm, 0.6 s probes", fontsize=11)
    fig.tight_layout()
    _save(fig, path)


def _save(fig: plt.Figure, path: Path) -> None:
    """Save a figure as PNG atomically."""
    atomic_savefig(fig, path, dpi=110)
    plt.close(fig)


def sweep(args: argparse.Namespace) -> pd.DataFrame:
    """Run the map; one row per (integrator, segments, modulus, timestep)."""
    columns = [(i, n, e) for i in args.integrators for n in args.segments for e in args.moduli]
    rows = []
    for integrator, n, modulus in tqdm(
        columns, desc="stability map", unit="column", file=sys.stderr
    ):
        found_stable = False
        for dt in sorted(args.timesteps, reverse=True):
            base = {
                "integrator": integrator,
                "n_segments": n,
                "youngs_modulus_pa": modulus,
                "timestep_s": dt,
            }
            if found_stable and not args.full:
                rows.append(
                    {
                        **base,
                        "stable": True,
                        "measured": False,
                        "reason": "",
                        "time_s": None,
                        "wall_time_s": 0.0,
                    }
                )
                continue
            result = stability.probe(
                probe_config(integrator, n, modulus, dt), duration_s=args.duration
            )
            found_stable = found_stable or result.stable
            rows.append(
                {
                    **base,
                    "stable": result.stable,
                    "measured": True,
                    "reason": result.reason,
                    "time_s": result.time_s,
                    "wall_time_s": result.wall_time_s,
                    "max_speed_m_s": result.stats.max_speed_m_s,
                    "max_penetration_m": result.stats.max_penetration_m,
                }
            )
    return pd.DataFrame(rows)


def boundary(frame: pd.DataFrame) -> dict[str, dict[int, tuple[float, ...]]]:
    """integrator -> segments -> per modulus, largest timestep with all smaller ones stable, s."""
    out: dict[str, dict[int, tuple[float, ...]]] = {}
    for (integrator, n), group in frame.groupby(["integrator", "n_segments"], sort=False):
        limits = []
        for _, column in group.groupby("youngs_modulus_pa", sort=True):
            column = column.sort_values("timestep_s")
            unstable = column.loc[~column["stable"], "timestep_s"]
            first_bad = unstable.min() if len(unstable) else float("inf")
            ok = column.loc[column["stable"] & (column["timestep_s"] < first_bad), "timestep_s"]
            limits.append(float(ok.max()) if len(ok) else 0.0)
        out.setdefault(str(integrator), {})[int(n)] = tuple(limits)
    return out


def plot(frame: pd.DataFrame, path: Path) -> None:
    """Stable/unstable scatter: rows integrators, columns segments, axes modulus x timestep."""
    integrators = list(dict.fromkeys(frame["integrator"]))
    segments = sorted(frame["n_segments"].unique())
    fig, axes = plt.subplots(
        len(integrators),
        len(segments),
        figsize=(2.4 * len(segments), 2.3 * len(integrators)),
        sharex=True,
        sharey=True,
        squeeze=False,
    )
    presets = {(p.numerics.integrator, p.n_segments): p for p in PRESETS.values()}
    for r, integrator in enumerate(integrators):
        for c, n in enumerate(segments):
            ax = axes[r][c]
            cell = frame[(frame["integrator"] == integrator) & (frame["n_segments"] == n)]
            styles = (
                (cell["stable"] & cell["measured"], "o", "tab:green", "stable"),
                (cell["stable"] & ~cell["measured"], "o", "#b8e0b8", "stable (inferred)"),
                (~cell["stable"], "x", "tab:red", "unstable"),
            )
            for mask, marker, color, label in styles:
                part = cell[mask]
                ax.scatter(
                    part["youngs_modulus_pa"] / 1e6,
                    part["timestep_s"] * 1e3,
                    marker=marker,
                    color=color,
                    s=22,
                    label=label,
                )
            preset = presets.get((integrator, n))
            if preset is not None:
                star = ax.scatter(
                    [1.0],
                    [preset.numerics.timestep_s * 1e3],
                    marker="*",
                    s=120,
                    color="black",
                    label=f"preset {preset.name} (E = 1 MPa)",
                )
                ax.legend(handles=[star], fontsize=6, loc="lower left")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xticks(sorted(frame["youngs_modulus_pa"].unique() / 1e6))
            ax.set_yticks(sorted(frame["timestep_s"].unique() * 1e3))
            ax.xaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
            ax.yaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
            ax.xaxis.set_minor_locator(ticker.NullLocator())
            ax.yaxis.set_minor_locator(ticker.NullLocator())
            ax.tick_params(labelsize=7)
            if r == 0:
                ax.set_title(f"{n} segments", fontsize=9)
            if c == 0:
                ax.set_ylabel(f"{integrator}\ntimestep (ms)", fontsize=9)
            if r == len(integrators) - 1:
                ax.set_xlabel("E (MPa)", fontsize=9)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles[:3], labels[:3], loc="upper right", ncol=3, fontsize=8)
    fig.suptitle(
        "Stability of three 300 mm filaments curling into each other in air (watchdog probe)",
        fontsize=11,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    _save(fig, path)


def main(argv: list[str] | None = None) -> int:
    """Run the sweep, write CSV and PNG, print the boundary table and preset envelopes."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/stability"))
    parser.add_argument("--full", action="store_true", help="run every point (no inferred points)")
    parser.add_argument("--duration", type=float, default=0.6, help="simulated seconds per probe")
    parser.add_argument("--integrators", nargs="+", default=list(stability.INTEGRATORS))
    parser.add_argument("--segments", nargs="+", type=int, default=list(stability.MAP_SEGMENTS))
    parser.add_argument("--moduli", nargs="+", type=float, default=list(stability.MAP_MODULI_PA))
    parser.add_argument(
        "--timesteps", nargs="+", type=float, default=list(stability.MAP_TIMESTEPS_S)
    )
    parser.add_argument(
        "--from-csv",
        type=Path,
        default=None,
        help="replot and summarize the CSVs of an earlier run in this folder instead of sweeping",
    )
    args = parser.parse_args(argv)
    if args.from_csv is not None:
        frame = pd.read_csv(args.from_csv / "stability_map.csv")
        coils = pd.read_csv(args.from_csv / "coil_map.csv")
    else:
        # Unstable probes are the point here: keep MuJoCo from printing (and logging) their
        # warnings.
        mujoco.set_mju_user_warning(lambda text: None)
        frame = sweep(args)
        atomic_write_csv(frame, args.out / "stability_map.csv")
        coils = coil_sweep(args)
        atomic_write_csv(coils, args.out / "coil_map.csv")
    plot(frame, args.out / "stability_map.png")
    plot_coil(coils, args.out / "coil_map.png")
    table = boundary(frame)
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
