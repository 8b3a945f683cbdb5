"""Figures drawn from result tables (never from a simulation)."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from entangle_bench.atomic import atomic_savefig  # noqa: E402
from entangle_bench.metrics.stats import success_table  # noqa: E402


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
    atomic_savefig(fig, path, dpi=120)
    plt.close(fig)
    return Path(path)
