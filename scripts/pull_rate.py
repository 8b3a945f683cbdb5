"""Rate independence of the pull-out test (`entangle_bench.studies.pull_rate`): two pull speeds, same seeds.

Usage: python scripts/pull_rate.py [--objects sphere eight_branch_tree] [--speeds 0.01 0.03] [--trials 3]
       [--preset balanced] [--set pull.max_travel_m=0.2] [--workers 2] [--out results/pull_rate]

Writes trials.csv, pull_rate.csv (per object and speed) and pull_rate_agreement.csv under --out and prints the
agreement: peak force and toughness agree when their bootstrap 95 % intervals of the median overlap.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from entangle_bench.errors import EntangleBenchError
from entangle_bench.studies.pull_rate import rate_specs, run_pull_rate


def main(argv: list[str] | None = None) -> int:
    """Run the study and print its agreement table; exit 2 on bad input."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--objects", nargs="+", default=["sphere", "eight_branch_tree", "cylinder_51"])
    parser.add_argument("--speeds", nargs="+", type=float, default=[0.01, 0.03], help="pull speeds, m/s")
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--preset", default=None)
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("results/pull_rate"))
    args = parser.parse_args(argv)
    try:
        specs = rate_specs(args.objects, args.speeds, args.trials, preset=args.preset, overrides=args.overrides)
    except EntangleBenchError as exc:
        print(f"pull_rate: error: {exc}", file=sys.stderr)
        return 2
    study = run_pull_rate(specs, args.out, args.workers)
    columns = ["config.object_name", "config.pull.speed_m_s", "scored", "peak_force_median_n",
               "peak_force_ci95_low_n", "peak_force_ci95_high_n", "toughness_median_j", "toughness_ci95_low_j",
               "toughness_ci95_high_j"]
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(study.table[columns].to_string(index=False, float_format=lambda v: f"{v:.3g}"))
        print(study.agreement.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
