"""Figures drawn from result tables (never from a simulation)."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from entangle_bench.atomic import atomic_savefig  # noqa: E402
from entangle_bench.metrics.stats import success_table  # noqa: E402


def save_figure(fig: plt.Figure, path: str | os.PathLike) -> Path:
    """Save `fig` as PNG at `path` atomically (`atomic.atomic_savefig`) and close it."""
    out = atomic_savefig(fig, path, dpi=120)
    plt.close(fig)
    return out


def plot_success_vs(rows: pd.DataFrame, x: str, path: str | os.PathLike, group: str = "task") -> Path:
    """Success rate with Wilson 95 % intervals against column `x`, one line per `group`; saved as PNG."""
    table = success_table(rows, [group, x])
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, sub in table.groupby(group):
        sub = sub.sort_values(x)
        xs = sub[x] * (1e3 if x.endswith("_m") else 1.0)
        ax.errorbar(
            xs,
            sub["success_rate"],
            yerr=[sub["success_rate"] - sub["ci95_low"], sub["ci95_high"] - sub["success_rate"]],
            marker="o",
            capsize=3,
            label=f"{str(name).split('/')[-1]}",
        )
    label = x.removeprefix("param.").removeprefix("config.")
    ax.set_xlabel(label.replace("_m", " (mm)") if x.endswith("_m") else label)
    ax.set_ylabel("success rate (Wilson 95 % CI)")
    ax.set_ylim(-0.05, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_pull_curves(
    curves: Mapping[str, Sequence[tuple[np.ndarray, np.ndarray]]], path: str | os.PathLike
) -> Path:
    """Pull force (mN) against hub displacement (mm), every trial's curve overlaid, one panel per condition."""
    names = list(curves) or ["(no stable trials)"]
    cols = min(3, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.5 * cols, 3.4 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names):
        for k, (displacement_m, force_n) in enumerate(curves.get(name, [])):
            ax.plot(np.asarray(displacement_m) * 1e3, np.asarray(force_n) * 1e3, lw=1, alpha=0.8, label=f"trial {k}")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("hub displacement (mm)")
        ax.set_ylabel("pull force (mN)")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(names) :]:
        ax.set_visible(False)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_toughness(table: pd.DataFrame, path: str | os.PathLike, label: str = "condition") -> Path:
    """Median toughness (mJ) per row of a pull-out table with its bootstrap 95 % interval, beside the reference.

    Symmetric-log axis: the simulated and measured values may lie orders of magnitude apart, and a toughness
    can be zero or negative.
    """
    fig, ax = plt.subplots(figsize=(max(5.0, 1.2 * len(table) + 2), 4))
    x = np.arange(len(table))
    median = table["toughness_median_j"].to_numpy(float) * 1e3
    low = table["toughness_ci95_low_j"].to_numpy(float) * 1e3
    high = table["toughness_ci95_high_j"].to_numpy(float) * 1e3
    errors = np.nan_to_num(np.stack([median - low, high - median]), nan=0.0)
    ax.errorbar(x - 0.1, median, yerr=errors, fmt="o", capsize=4, label="simulated: median, bootstrap 95 % CI")
    reference = table["reference_toughness_j"].to_numpy(float) * 1e3
    ax.plot(x + 0.1, reference, "rs", label="reference (Becker et al. 2022, 172 kPa)")
    finite = np.abs(np.concatenate([median, low, high, reference]))
    finite = finite[np.isfinite(finite) & (finite > 0)]
    ax.set_yscale("symlog", linthresh=float(finite.min()) if len(finite) else 1e-3)
    ax.set_xticks(x, [str(v) for v in table[label]], rotation=20, fontsize=8)
    ax.set_ylabel("entanglement toughness (mJ)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path)


def plot_hold_creep(series: pd.DataFrame, path: str | os.PathLike, margin_m: float | None = None) -> Path:
    """The object's lowest point (mm) over the hold, one line per solver variant (`studies.hold_creep` series)."""
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, sub in series.groupby("variant", sort=False):
        ax.plot(sub["t_s"], 1e3 * sub["low_m"], label=name)
    if margin_m is not None:
        ax.axhline(1e3 * margin_m, color="k", ls="--", lw=0.8, label="success margin")
    ax.set_xlabel("time since the hold began (s)")
    ax.set_ylabel("object's lowest point (mm)")
    ax.set_title("Hold from one state, per solver variant")
    ax.legend()
    fig.tight_layout()
    return save_figure(fig, path)
