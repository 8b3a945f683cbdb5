"""Stability map: Young's modulus x timestep x segments for every integrator, as CSV and PNG.

Usage: python scripts/stability_map.py [--out results/stability] [--full] [--duration 0.6]

Each point is one `entangle_bench.stability.probe` of `stability.MAP_GRIPPER`: three reference filaments
(300 mm, r = 0.7 mm) 8.7 mm apart, every contact effect on, hanging in air from a fixed hub, every joint
perturbed by 0.05 rad, the pressure ramped in 0.3 s to the
reference 172 kPa, held to `--duration`; the law's calibration is scaled with E so that every modulus curls
to the same reference 12.5 mm coil, under the runtime watchdog (NaN/Inf, MuJoCo warnings, energy above the
actuation work + 10 %, speed above 10 m/s). Each integrator runs with the numerics of the first preset that
uses it (euler: balanced, implicitfast: accurate), otherwise with the default preset's, only the integrator,
timestep and segments changed. By default each (integrator, segments, modulus) column is scanned from the
largest timestep down and stops at the first stable one: smaller timesteps are then marked stable without
running ("inferred"); `--full` runs every point. Prints the boundary table kept in
`entangle_bench.stability.ENVELOPE` and the resulting envelope of every preset.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
from pathlib import Path

import matplotlib
import mujoco

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pandas as pd
from tqdm import tqdm

from entangle_bench import stability
from entangle_bench.filament import FilamentParams
from entangle_bench.presets import PRESETS
from entangle_bench.results import atomic_write_csv
from entangle_bench.scene import SceneConfig


def probe_config(integrator: str, n_segments: int, modulus_pa: float, timestep_s: float) -> SceneConfig:
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


def sweep(args: argparse.Namespace) -> pd.DataFrame:
    """Run the map; one row per (integrator, segments, modulus, timestep)."""
    columns = [
        (i, n, e) for i in args.integrators for n in args.segments for e in args.moduli
    ]
    rows = []
    for integrator, n, modulus in tqdm(columns, desc="stability map", unit="column", file=sys.stderr):
        found_stable = False
        for dt in sorted(args.timesteps, reverse=True):
            base = {
                "integrator": integrator,
                "n_segments": n,
                "youngs_modulus_pa": modulus,
                "timestep_s": dt,
            }
            if found_stable and not args.full:
                rows.append({**base, "stable": True, "measured": False, "reason": "", "time_s": None,
                             "wall_time_s": 0.0})
                continue
            result = stability.probe(probe_config(integrator, n, modulus, dt), duration_s=args.duration)
            found_stable = found_stable or result.stable
            rows.append({**base, "stable": result.stable, "measured": True, "reason": result.reason,
                         "time_s": result.time_s, "wall_time_s": result.wall_time_s,
                         "max_speed_m_s": result.stats.max_speed_m_s,
                         "max_penetration_m": result.stats.max_penetration_m})
    return pd.DataFrame(rows)


def boundary(frame: pd.DataFrame) -> dict[str, dict[int, tuple[float, ...]]]:
    """integrator -> segments -> largest timestep below which every timestep is stable, per modulus (s)."""
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
    """Stable/unstable scatter: rows integrators, columns segment counts, axes modulus x timestep."""
    integrators = list(dict.fromkeys(frame["integrator"]))
    segments = sorted(frame["n_segments"].unique())
    fig, axes = plt.subplots(
        len(integrators), len(segments), figsize=(2.4 * len(segments), 2.3 * len(integrators)),
        sharex=True, sharey=True, squeeze=False,
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
                ax.scatter(part["youngs_modulus_pa"] / 1e6, part["timestep_s"] * 1e3, marker=marker,
                           color=color, s=22, label=label)
            preset = presets.get((integrator, n))
            if preset is not None:
                ax.scatter([1.0], [preset.numerics.timestep_s * 1e3], marker="*", s=120,
                           color="black", label=f"preset {preset.name}")
                ax.legend(fontsize=6, loc="lower left")
            ax.set_xscale("log")
            ax.set_yscale("log")
            if r == 0:
                ax.set_title(f"{n} segments", fontsize=9)
            if c == 0:
                ax.set_ylabel(f"{integrator}\ntimestep (ms)", fontsize=9)
            if r == len(integrators) - 1:
                ax.set_xlabel("E (MPa)", fontsize=9)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles[:3], labels[:3], loc="upper right", ncol=3, fontsize=8)
    fig.suptitle("Stability of three 300 mm filaments curling into each other in air (watchdog probe)",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    """Run the sweep, write CSV and PNG, print the boundary table and preset envelopes."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/stability"))
    parser.add_argument("--full", action="store_true", help="run every point (no inferred points)")
    parser.add_argument("--duration", type=float, default=0.6, help="simulated seconds per probe")
    parser.add_argument("--integrators", nargs="+", default=list(stability.INTEGRATORS))
    parser.add_argument("--segments", nargs="+", type=int, default=list(stability.MAP_SEGMENTS))
    parser.add_argument("--moduli", nargs="+", type=float, default=list(stability.MAP_MODULI_PA))
    parser.add_argument("--timesteps", nargs="+", type=float, default=list(stability.MAP_TIMESTEPS_S))
    args = parser.parse_args(argv)
    # Unstable probes are the point here: keep MuJoCo from printing (and logging) each of their warnings.
    mujoco.set_mju_user_warning(lambda text: None)
    frame = sweep(args)
    atomic_write_csv(frame, args.out / "stability_map.csv")
    plot(frame, args.out / "stability_map.png")
    table = boundary(frame)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"probes run: {int(frame['measured'].sum())}, wall {frame['wall_time_s'].sum():.0f} s")
    print("ENVELOPE = {")
    for integrator, by_n in table.items():
        print(f'    "{integrator}": {{')
        for n, limits in by_n.items():
            print(f"        {n}: ({', '.join(f'{v:g}' for v in limits)}),")
        print("    },")
    print("}")
    print("| preset | integrator | segments | timestep (ms) | largest stable timestep at E = 1 MPa (ms) "
          "| E range stable at the preset timestep (MPa) | largest segments at the preset timestep |")
    print("|---|---|---|---|---|---|---|")
    for name, summary in stability.preset_envelopes(table).items():
        print(f"| {name} | {summary['integrator']} | {summary['n_segments']} | "
              f"{summary['timestep_s'] * 1e3:g} | {summary['max_timestep_s'] * 1e3:g} | "
              f"{summary['modulus_range']} | {summary['max_segments']} |")
    print(f"csv: {args.out / 'stability_map.csv'}  plot: {args.out / 'stability_map.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
