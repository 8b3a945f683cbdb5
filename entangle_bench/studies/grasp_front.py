"""Numerical presets judged on grasp outcomes (issue 11, item 4): numerical variants of one gripper against a fine run.

A variant is a set of trial rows of one condition (task, centering offset) that differ from the fine run's only
in their numerics (`config.numerics.*`, the segment count and the stretch joint's armature) and their seeds.
`front_table` gives per variant the success over its scored trials with the Wilson 95 % interval, the unstable
count, the cost (median wall seconds per simulated second over its stable rows: it depends on what ran beside
each trial, so compare variants run alike), the outcomes on the seeds both scored, and the verdict against the
fine run: `differs` where the intervals are disjoint or where the seeds both scored reject equal success (the
exact McNemar test at `PAIRED_ALPHA`: a seed fixes the initial state, so the same seed under two numerics is a
pair, and pairs detect a change that two intervals of 20 trials cannot), `agrees` on at least `MIN_TRIALS`
scored trials each otherwise, `open` with fewer. `toughness_front` judges pull-out toughness on intervals
alone (bootstrap interval of the median; `MIN_PULLS` scored pulls per object). `cheapest_agreeing` names the
default the issue asks for: the cheapest variant that agrees with the fine run on every measure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from entangle_bench.atomic import atomic_savefig  # noqa: E402
from entangle_bench.calibration import MIN_TRIALS, Rate, rate_of  # noqa: E402
from entangle_bench.errors import ParameterError  # noqa: E402
from entangle_bench.metrics.pullout import intervals_overlap, pullout_table  # noqa: E402
from entangle_bench.metrics.stats import paired_exact_p  # noqa: E402
from entangle_bench.results import SCORED, SUCCESS, UNSTABLE  # noqa: E402

#: Config columns a variant may change: the numerics and the segment count (what `presets.apply_preset` sets),
#: and the stretch joint's armature (an inertia that changes no equilibrium, there for the step).
NUMERICAL_PREFIXES = ("config.numerics.", "config.gripper.filament.n_segments",
                      "config.gripper.filament.stretch_armature_ratio")
#: Scored pull-outs per object before a toughness verdict is `agrees`.
MIN_PULLS = 5
#: Level of the paired test below which a variant `differs` from the fine run.
PAIRED_ALPHA = 0.05
AGREES, DIFFERS, OPEN = "agrees", "differs", "open"


def check_same_gripper(fine: pd.DataFrame, variant: pd.DataFrame, label: str) -> None:
    """Raise ParameterError if `variant` changes a config field other than the numerics (`NUMERICAL_PREFIXES`).

    Columns that only one of the two has (fields added after the other was logged) are not compared.
    """
    for column in sorted(set(fine.columns) & set(variant.columns)):
        if not column.startswith("config.") or column.startswith(NUMERICAL_PREFIXES):
            continue
        ours, theirs = ({_canonical(v) for v in frame[column].dropna()} for frame in (variant, fine))
        if ours != theirs:
            raise ParameterError(f"variant {label!r} differs from the fine run in {column} ({sorted(ours)} against "
                                 f"{sorted(theirs)}); a variant may change only {', '.join(NUMERICAL_PREFIXES)}")


def _canonical(value: object) -> str:
    """A config value as text that does not depend on the file it was read from (8 and 8.0, list and array)."""
    if isinstance(value, str):
        try:
            return repr(float(value))
        except ValueError:
            return value
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if np.ndim(value):
        return "(" + ", ".join(_canonical(v) for v in np.asarray(value).tolist()) + ")"
    return repr(float(value))


def _mode(column: pd.Series) -> object:
    values = column.dropna()
    return values.mode().iloc[0] if len(values) else math.nan


def verdict(rate: Rate, fine: Rate, paired_p: float = 1.0) -> str:
    """`agrees`, `differs` or `open` (see the module docstring); `paired_p` is the paired test's p-value."""
    (low, high), (fine_low, fine_high) = rate.interval, fine.interval
    if rate.scored and fine.scored and not intervals_overlap(low, high, fine_low, fine_high):
        return DIFFERS
    if paired_p < PAIRED_ALPHA:
        return DIFFERS
    return AGREES if rate.enough and fine.enough else OPEN


def cost_per_sim_s(rows: pd.DataFrame) -> float:
    """Median wall seconds per simulated second over the stable rows (NaN without one)."""
    stable = rows[rows["outcome"] != UNSTABLE]
    return float(np.median(stable["wall_time_s"] / stable["sim_time_s"])) if len(stable) else math.nan


def front_table(variants: Mapping[str, pd.DataFrame], fine: str) -> pd.DataFrame:
    """One row per variant (already filtered to one condition) judged against the variant named `fine`."""
    if fine not in variants:
        raise ParameterError(f"fine run {fine!r} is not among the variants ({', '.join(variants)})")
    for label, rows in variants.items():
        check_same_gripper(variants[fine], rows, label)
    base = rate_of(variants[fine])
    fine_outcome = variants[fine][variants[fine]["outcome"].isin(SCORED)].set_index("seed")["outcome"]
    fine_cost = cost_per_sim_s(variants[fine])
    out = []
    for label, rows in variants.items():
        rate = rate_of(rows)
        low, high = rate.interval
        outcome = rows[rows["outcome"].isin(SCORED)].set_index("seed")["outcome"]
        common = outcome.index.intersection(fine_outcome.index)
        ours, theirs = outcome[common] == SUCCESS, fine_outcome[common] == SUCCESS
        fine_only, variant_only = int((theirs & ~ours).sum()), int((ours & ~theirs).sum())
        paired_p = paired_exact_p(fine_only, variant_only)
        cost = cost_per_sim_s(rows)
        out.append({
            "variant": label,
            "integrator": _mode(rows["config.numerics.integrator"]),
            "timestep_ms": 1e3 * float(_mode(rows["config.numerics.timestep_s"])),
            "segments": _mode(rows["config.gripper.filament.n_segments"]),
            "trials": len(rows),
            "unstable": rate.unstable,
            "retried": int(rows.get("retried_half_timestep", pd.Series(dtype=bool)).fillna(False).astype(bool).sum()),
            "scored": rate.scored,
            "successes": rate.successes,
            "success_rate": rate.value,
            "ci95_low": low,
            "ci95_high": high,
            "paired_seeds": len(common),
            "paired_same_outcome": int((outcome[common] == fine_outcome[common]).sum()),
            "paired_fine_only": fine_only,
            "paired_variant_only": variant_only,
            "paired_p": paired_p,
            "wall_per_sim_s": cost,
            "cost_ratio": cost / fine_cost if fine_cost else math.nan,
            "verdict": "fine run" if label == fine else verdict(rate, base, paired_p),
        })
    return pd.DataFrame(out)


def toughness_front(pullouts: Mapping[str, pd.DataFrame], fine: str) -> pd.DataFrame:
    """Per variant and object: median pull-out toughness with its bootstrap 95 % interval, against the fine run's.

    `pullouts` maps variant labels to pull-out rows (`pullout_table`'s input); a verdict is `agrees` with at
    least `MIN_PULLS` scored pulls on both sides and overlapping intervals, `differs` with disjoint ones.
    """
    if fine not in pullouts:
        raise ParameterError(f"fine run {fine!r} is not among the pull-out variants ({', '.join(pullouts)})")
    for label, rows in pullouts.items():
        for name, group in rows.groupby("config.object_name"):
            base = pullouts[fine][pullouts[fine]["config.object_name"] == name]
            if len(base):
                check_same_gripper(base, group, f"{label}, {name}")
    tables = {label: pullout_table(rows, ["config.object_name"]).set_index("config.object_name")
              for label, rows in pullouts.items()}
    out = []
    for label, table in tables.items():
        for name, entry in table.iterrows():
            base = tables[fine].loc[name] if name in tables[fine].index else None
            bounds = (entry["toughness_ci95_low_j"], entry["toughness_ci95_high_j"])
            if label == fine:
                judged = "fine run"
            elif base is None:
                judged = OPEN
            elif not intervals_overlap(*bounds, base["toughness_ci95_low_j"], base["toughness_ci95_high_j"]):
                judged = DIFFERS if entry["scored"] > 1 and base["scored"] > 1 else OPEN
            else:
                judged = AGREES if min(entry["scored"], base["scored"]) >= MIN_PULLS else OPEN
            out.append({"variant": label, "object": name, "scored": int(entry["scored"]),
                        "unstable": int(entry["unstable"]), "toughness_median_j": entry["toughness_median_j"],
                        "ci95_low_j": bounds[0], "ci95_high_j": bounds[1], "verdict": judged})
    return pd.DataFrame(out)


def cheapest_agreeing(front: pd.DataFrame, toughness: pd.DataFrame | None = None) -> str | None:
    """The cheapest variant (by `wall_per_sim_s`) whose success, and toughness on every object, agree with the
    fine run; the fine run itself if none does; None while the fine run's own verdict is still open (fewer than
    `MIN_TRIALS` scored trials)."""
    fine_row = front[front["verdict"] == "fine run"].iloc[0]
    if fine_row["scored"] < MIN_TRIALS:
        return None
    candidates = front[front["verdict"] == AGREES]
    if toughness is not None and not toughness.empty:
        judged = toughness[toughness["verdict"] != "fine run"].groupby("variant")["verdict"]
        tough_ok = {label for label, verdicts in judged if (verdicts == AGREES).all()}
        candidates = candidates[candidates["variant"].isin(tough_ok)]
    if candidates.empty:
        return str(fine_row["variant"])
    return str(candidates.sort_values("wall_per_sim_s").iloc[0]["variant"])


def plot_front(front: pd.DataFrame, path: Path, title: str) -> None:
    """Success rate with its Wilson 95 % interval against wall per simulated second, one point per variant."""
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for k, row in enumerate(front.itertuples()):
        if not row.scored:
            continue
        error = [[row.success_rate - row.ci95_low], [row.ci95_high - row.success_rate]]
        marker = "s" if row.verdict == "fine run" else "o"
        ax.errorbar(row.wall_per_sim_s, 100 * row.success_rate, yerr=100 * np.asarray(error), fmt=marker,
                    color=f"C{k}", capsize=4, label=f"{row.variant}: {row.successes}/{row.scored} ({row.verdict})")
    ax.set(xscale="log", ylim=(-5, 105), xlabel="wall s per simulated s (median over stable rows)",
           ylabel="success, % (Wilson 95 %)", title=title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    atomic_savefig(fig, path, dpi=120)
    plt.close(fig)
