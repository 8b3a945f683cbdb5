"""Profile one trial: where its time goes, per phase (MuJoCo stage timers, contacts, solver iterations).

Usage: python scripts/profile_trial.py [--task eight_branch_tree] [--preset balanced] [--seed 0]
                                       [--set a.b=v ...] [--out profile.csv]
Prints the outcome and a markdown table (wall s per simulated s on this core, us per physics step, the
share of each MuJoCo stage and of the Python between steps). `studies.profile.StageProfile` does the work.
"""

from __future__ import annotations

import argparse
import platform
import sys
from pathlib import Path

import mujoco

from entangle_bench.results import atomic_write_csv
from entangle_bench.studies.accuracy_time import markdown
from entangle_bench.studies.profile import profile_trial
from entangle_bench.suite import TASKS, resolve_config


def main(argv: list[str] | None = None) -> int:
    """Run the trial, print and optionally write the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="eight_branch_tree")
    parser.add_argument("--preset", default="balanced")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")
    parser.add_argument("--out", type=Path, default=None, help="also write the table as CSV")
    args = parser.parse_args(argv)
    task = TASKS.resolve(args.task)
    config = resolve_config(task, args.preset, args.overrides)
    result, table = profile_trial(task, config, args.seed)
    row = result.row
    print(
        f"machine: {platform.machine()}, python {platform.python_version()}, mujoco {mujoco.__version__}; "
        f"{task} preset {args.preset} seed {args.seed} {' '.join(args.overrides)}"
    )
    print(f"outcome: {row['outcome']} {row.get('failure_mode') or row.get('unstable_reason') or ''}")
    print(markdown(table))
    if args.out is not None:
        atomic_write_csv(table, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
