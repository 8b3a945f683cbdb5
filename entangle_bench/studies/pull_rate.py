"""Rate independence of the pull-out test: the same seeded trials at two or more pull speeds.

`rate_specs` makes the trials: every object crossed with every speed, the same seeds at each speed (so the
grasps before the pull are the same; only `pull.speed_m_s` differs, so a trial already run, e.g. by the
`pullout` suite, has the same trial id and is reused from the log). `run_pull_rate` runs them through the
runner (resumable trial log under `out`), then per (object, speed) the pull-out table
(`metrics.pullout.pullout_table`: median, IQR and bootstrap 95 % interval of peak force and toughness) and,
slowest against fastest speed per object, whether they agree (`metrics.pullout.rate_agreement`: the bootstrap
intervals of the medians overlap). `scripts/pull_rate.py` runs it from the command line.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from entangle_bench.errors import ParameterError
from entangle_bench.executors import make_executor
from entangle_bench.metrics.pullout import pullout_table, rate_agreement
from entangle_bench.results import TrialLog, atomic_write_csv
from entangle_bench.runner import TrialSpec, run_trials
from entangle_bench.suites import task_suite

#: The rows' column of the pull speed (every row carries its resolved configuration).
SPEED = "config.pull.speed_m_s"


@dataclass(frozen=True, eq=False)
class RateStudy:
    """The study's tables: one row per (object, speed), and the agreement per object."""

    table: pd.DataFrame
    agreement: pd.DataFrame


def rate_specs(
    objects: Sequence[str],
    speeds_m_s: Sequence[float],
    trials: int,
    *,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    seed: int = 0,
) -> list[TrialSpec]:
    """Seeded pull-out trials of every object at every speed (m/s); bad speeds raise before anything runs."""
    speeds = sorted({float(v) for v in speeds_m_s})
    if len(speeds) < 2:
        raise ParameterError(f"a rate study needs at least two different pull speeds, got {list(speeds_m_s)}")
    specs = []
    for name in objects:
        for speed in speeds:
            suite = task_suite(
                f"pullout/{name}",
                preset=preset,
                overrides=[*overrides, f"pull.speed_m_s={speed!r}"],
                trials=trials,
                seed=seed,
            )
            specs += [dataclasses.replace(spec, condition=f"{name} v={speed:g} m/s") for spec in suite.specs]
    return specs


def run_pull_rate(specs: Sequence[TrialSpec], out: Path, workers: int = 1, progress: bool = True) -> RateStudy:
    """Run the trials (skipping those already in `out/trials.jsonl`), write and return the study's tables."""
    out = Path(out)
    log = TrialLog(out / "trials.jsonl")
    run_trials(specs, log, make_executor(workers), progress=progress)
    rows = log.frame()
    rows = rows[rows["trial_id"].isin({spec.trial_id for spec in specs})]
    table = pullout_table(rows, ["config.object_name", SPEED])
    agreement = rate_agreement(table, "config.object_name", SPEED)
    atomic_write_csv(rows, out / "trials.csv")
    atomic_write_csv(table, out / "pull_rate.csv")
    atomic_write_csv(agreement, out / "pull_rate_agreement.csv")
    return RateStudy(table, agreement)
