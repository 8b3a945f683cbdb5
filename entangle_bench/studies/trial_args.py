"""Command-line arguments shared by the one-trial studies (`scripts/profile_trial.py`,
`scripts/contact_depth_by_phase.py`, `scripts/bench_solvers.py`): task, preset, seed and `--set` overrides."""

from __future__ import annotations

import argparse
from typing import Any

from entangle_bench.suite import TASKS, resolve_config


def add_trial_arguments(parser: argparse.ArgumentParser) -> None:
    """Add --task (default eight_branch_tree), --preset (balanced), --seed (0) and repeatable --set a.b=v."""
    parser.add_argument("--task", default="eight_branch_tree")
    parser.add_argument("--preset", default="balanced")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")


def trial_from_arguments(args: argparse.Namespace) -> tuple[str, Any]:
    """The registered task name and its resolved config (preset and overrides applied) from parsed arguments."""
    task = TASKS.resolve(args.task)
    return task, resolve_config(task, args.preset, args.overrides)
