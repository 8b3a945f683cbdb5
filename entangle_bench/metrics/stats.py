"""Success statistics: rates with Wilson score intervals; the exact paired test of two methods on the same seeds."""

from __future__ import annotations

import pandas as pd
from scipy.stats import binomtest

from entangle_bench.errors import ParameterError
from entangle_bench.results import FAILED, SCORED, SUCCESS, UNSTABLE


def wilson_interval(successes: int, trials: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (Wilson 1927; scipy); (0, 1) for zero trials."""
    if trials == 0:
        return 0.0, 1.0
    if not 0 <= successes <= trials:
        raise ParameterError(f"successes = {successes} must be between 0 and trials = {trials}")
    ci = binomtest(successes, trials).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def paired_exact_p(only_first: int, only_second: int) -> float:
    """Two-sided exact McNemar p-value: two methods run on the same seeds, `only_first` seeds succeeding with
    the first alone and `only_second` with the second alone (the discordant pairs; scipy's binomial test at
    1/2). 1 without a discordant pair."""
    if min(only_first, only_second) < 0:
        raise ParameterError(f"discordant pair counts must be >= 0, got {only_first} and {only_second}")
    discordant = only_first + only_second
    return float(binomtest(only_first, discordant).pvalue) if discordant else 1.0


def success_table(rows: pd.DataFrame, by: list[str]) -> pd.DataFrame:
    """Per condition: trials, successes, rate over scored trials and its Wilson 95 % CI, failure modes.

    Only trials the task decided (outcome success or failure) are scored. Unstable trials (stopped by the
    watchdog) and failed ones (not run: worker died, or the trial raised) are counted in their own columns and
    never enter the rate.
    """
    out = []
    for key, group in rows.groupby(by, sort=True, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        stable = group[group["outcome"].isin(SCORED)]
        n, k = len(stable), int((stable["outcome"] == SUCCESS).sum())
        low, high = wilson_interval(k, n)
        modes = stable.loc[stable["outcome"] != SUCCESS, "failure_mode"].value_counts()
        out.append(
            dict(zip(by, key))
            | {
                "trials": len(group),
                "unstable": int((group["outcome"] == UNSTABLE).sum()),
                "failed": int((group["outcome"] == FAILED).sum()),
                "successes": k,
                "success_rate": k / n if n else float("nan"),
                "ci95_low": low,
                "ci95_high": high,
                "failure_modes": ";".join(f"{m}:{c}" for m, c in modes.items()),
            }
        )
    return pd.DataFrame(out)
