"""`entangle-bench tasks`: registered tasks, suite files, rod cases and presets."""

from __future__ import annotations

import argparse

from entangle_bench import suites
from entangle_bench.presets import PRESETS
from entangle_bench.rods.case import ROD_CASES
from entangle_bench.suite import TASKS


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Attach the `tasks` subcommand."""
    p = sub.add_parser("tasks", help="list tasks, suites and presets")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Print the lists."""
    print("tasks:")
    for name in TASKS.names():
        entry = TASKS.entry(name)
        print(f"  {name:36s} [{','.join(entry.tags)}] {entry.description}")
    print("suites (tasks/*.toml):")
    for name in suites.SUITES.names():
        suite = suites.load_suite(name)
        print(f"  {name:24s} {len(suite.specs):5d} trials  {suite.description}")
    print("rod cases (entangle-bench rod NAME):")
    print("  " + ", ".join(ROD_CASES.names()))
    print("presets:")
    for name, preset in PRESETS.items():
        n = preset.numerics
        print(f"  {name:10s} segments={preset.n_segments} dt={n.timestep_s}s {n.integrator}/{n.solver}")
    return 0
