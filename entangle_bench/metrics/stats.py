"""Success statistics: rates with Wilson score intervals."""

from __future__ import annotations

import math

import pandas as pd


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson 1927); (0, 1) for zero trials."""
    if trials == 0:
        return 0.0, 1.0
    if not 0 <= successes <= trials:
        raise ValueError(f"successes = {successes} must be between 0 and trials = {trials}")
    p = successes / trials
    denom = 1 + z**2 / trials
    center = (p + z**2 / (2 * trials)) / denom
    half = z * math.sqrt(p * (1 - p) / trials + z**2 / (4 * trials**2)) / denom
    return max(0.0, center - half), min(1.0, center + half)


def success_table(rows: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Per condition: trials, stable trials, successes, rate over stable trials and its Wilson 95 % CI.

    Unstable trials are counted separately and never enter the rate.
    """
    out = []
    for key, group in rows.groupby(by, sort=True, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        stable = group[group["outcome"] != "unstable"]
        n, k = len(stable), int((stable["outcome"] == "success").sum())
        low, high = wilson_interval(k, n)
        modes = stable.loc[stable["outcome"] != "success", "failure_mode"].value_counts()
        out.append(
            dict(zip(by, key))
            | {
                "trials": len(group),
                "unstable": int((group["outcome"] == "unstable").sum()),
                "successes": k,
                "success_rate": k / n if n else float("nan"),
                "ci95_low": low,
                "ci95_high": high,
                "failure_modes": ";".join(f"{m}:{c}" for m, c in modes.items()),
            }
        )
    return pd.DataFrame(out)
