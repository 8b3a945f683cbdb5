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

from entangle_bench.results import atomic_write_csv, markdown
from entangle_bench.studies.profile import profile_trial
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def main(argv: list[str] | None = None) -> int:
    """Run the trial, print and optionally write the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--out", type=Path, default=None, help="also write the table as CSV")
    args = parser.parse_args(argv)
    task, config = trial_from_arguments(args)
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
