"""Stability map: Young's modulus x timestep x segments for every integrator, plus tight coils.

Rod map: each point is one probe (task `probe/curl_in_air`, `suite.probe`) of `stability.MAP_GRIPPER`: three
reference filaments (300 mm, r = 0.7 mm) 8.7 mm apart, every contact effect on, hanging in air from a fixed
hub, every joint perturbed by 0.05 rad, the pressure ramped in 0.3 s to the reference 172 kPa, held to the
probe duration; the law's calibration is scaled with E so that every modulus curls to the same reference
12.5 mm coil. Probes run through the runner (`runner.simulate`) under its watchdog (NaN/Inf, MuJoCo warnings,
energy above the actuation work + 10 %, speed above 10 m/s), like every trial. Each integrator runs with
`stability.MAP_NUMERICS`, only the timestep and segments changed. By default each (integrator, segments,
modulus) column is scanned from the largest timestep down and stops at the first stable one: smaller
timesteps are then marked stable without running ("inferred"); `full=True` runs every point (a full run of
euler and rk4 at 24 and 64 segments found no column where a stable timestep had an unstable smaller one).

Coil sweep: one filament, with every contact on and with none, curling to coils of 2.1-12.5 mm (E 1-10 MPa,
euler and implicitfast): the largest timestep stable for two seeds, against the coil rate c kappa^2.

Both take `overrides` (`a.b=value`, as `--set`) applied to every probe: the map of other numerics or contact
settings (e.g. the grasp calibration candidate's hinge chain and stiff elliptic contact). The swept fields
(SWEPT_FIELDS) cannot be overridden.

`boundary` turns a map into the ENVELOPE table kept in `entangle_bench.stability` (a test checks that the
stored map gives the stored table). `scripts/stability_map.py` runs it (about 6 minutes on one core) and
prints the tables.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.ticker as ticker  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from tqdm import tqdm  # noqa: E402

from entangle_bench import effects as fx  # noqa: E402
from entangle_bench import stability  # noqa: E402
from entangle_bench.atomic import atomic_savefig  # noqa: E402
from entangle_bench.config import apply_overrides  # noqa: E402
from entangle_bench.errors import ParameterError  # noqa: E402
from entangle_bench.filament import REFERENCE_COIL_RADIUS_M, FilamentParams  # noqa: E402
from entangle_bench.gripper import GripperParams  # noqa: E402
from entangle_bench.presets import PRESETS  # noqa: E402
from entangle_bench.runner import TrialResult, simulate  # noqa: E402
from entangle_bench.suite.probe import ProbeConfig  # noqa: E402
from entangle_bench.watchdog import WatchdogLimits  # noqa: E402

PROBE_TASK = "probe/curl_in_air"

#: Simulated seconds of each map probe.
MAP_DURATION_S = 0.6

#: Fields every map point sets itself: an override of one of them is refused.
SWEPT_FIELDS = (
    "numerics.integrator",
    "numerics.timestep_s",
    "gripper.filament.n_segments",
    "gripper.filament.youngs_modulus_pa",
    "gripper.filament.curvature_calibration",
)


def check_overrides(overrides: Sequence[str]) -> None:
    """ParameterError naming an override of a swept field (SWEPT_FIELDS) or one the probe has no field for."""
    for item in overrides:
        key = item.partition("=")[0].strip()
        if key in SWEPT_FIELDS:
            raise ParameterError(f"--set {item!r}: {key} is swept by the map; the map sets {', '.join(SWEPT_FIELDS)}")
    apply_overrides(probe_config("euler", 8, 1e6, 1e-3), overrides)


def probe(config: ProbeConfig, seed: int = 0, limits: WatchdogLimits | None = None) -> TrialResult:
    """One stability probe through the runner, under the probe's watchdog limits unless `limits` is given."""
    return simulate(PROBE_TASK, config, seed, limits=limits)


def probe_config(
    integrator: str,
    n_segments: int,
    modulus_pa: float,
    timestep_s: float,
    duration_s: float = MAP_DURATION_S,
    overrides: Sequence[str] = (),
) -> ProbeConfig:
    """The map's filament array with the map's numerics for `integrator` (Pa, s), then `overrides`."""
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
    return apply_overrides(ProbeConfig(gripper=gripper, numerics=numerics, duration_s=duration_s), overrides)


def coil_config(
    integrator: str,
    radius_m: float,
    modulus_pa: float,
    timestep_s: float,
    contact: bool,
    duration_s: float = MAP_DURATION_S,
    overrides: Sequence[str] = (),
) -> ProbeConfig:
    """One reference filament curling to a coil of `radius_m` (m), every contact on or none, then `overrides`.

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
    config = ProbeConfig(gripper=gripper, effects=effects, numerics=numerics, duration_s=duration_s)
    return apply_overrides(config, overrides)


def _timed_probe(config: ProbeConfig, seed: int = 0) -> tuple[TrialResult, float]:
    """A probe and its wall time, s."""
    start = time.perf_counter()
    result = probe(config, seed)
    return result, time.perf_counter() - start


def coil_sweep(
    timesteps_s: Sequence[float] = stability.MAP_TIMESTEPS_S,
    duration_s: float = MAP_DURATION_S,
    overrides: Sequence[str] = (),
) -> pd.DataFrame:
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
        for dt in sorted(timesteps_s, reverse=True):
            config = coil_config(integrator, radius, modulus, dt, contact, duration_s, overrides)
            results = [_timed_probe(config, seed=s) for s in (0, 1)]
            wall += sum(w for _, w in results)
            if all(r.stable for r, _ in results):
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


def sweep(
    integrators: Sequence[str] = stability.INTEGRATORS,
    segments: Sequence[int] = stability.MAP_SEGMENTS,
    moduli_pa: Sequence[float] = stability.MAP_MODULI_PA,
    timesteps_s: Sequence[float] = stability.MAP_TIMESTEPS_S,
    duration_s: float = MAP_DURATION_S,
    full: bool = False,
    overrides: Sequence[str] = (),
) -> pd.DataFrame:
    """Run the map; one row per (integrator, segments, modulus, timestep); `full` measures inferred points too."""
    columns = [(i, n, e) for i in integrators for n in segments for e in moduli_pa]
    rows = []
    for integrator, n, modulus in tqdm(
        columns, desc="stability map", unit="column", file=sys.stderr
    ):
        found_stable = False
        for dt in sorted(timesteps_s, reverse=True):
            base = {
                "integrator": integrator,
                "n_segments": n,
                "youngs_modulus_pa": modulus,
                "timestep_s": dt,
            }
            if found_stable and not full:
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
            result, wall = _timed_probe(probe_config(integrator, n, modulus, dt, duration_s, overrides))
            found_stable = found_stable or result.stable
            rows.append(
                {
                    **base,
                    "stable": result.stable,
                    "measured": True,
                    "reason": result.reason,
                    "time_s": result.time_s,
                    "wall_time_s": wall,
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


def write_outputs(frame: pd.DataFrame, coils: pd.DataFrame, out: Path) -> None:
    """Plot the map and the coil sweep as stability_map.png and coil_map.png under `out`."""
    plot(frame, out / "stability_map.png")
    plot_coil(coils, out / "coil_map.png")
