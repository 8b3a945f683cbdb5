"""Grasp calibration: run a candidate's suites (optional) and judge its rows against the reference targets (a)–(d).

The candidate is the `calibration` suite's settings plus `--set` overrides (e.g. a solver). With `--run N` it
first runs the suite with N seeded trials per condition into OUT and the pull-out suite with the same gripper,
contact and numerics (`--pullout-trials`, default 5) into OUT/pullout, and again with the object welded in
mid-air (no ground to pinch the filaments, no fixture to lasso) into OUT/pullout_midair; all resume where a
previous run stopped and retry unstable trials at half the timestep. It then writes OUT/targets.md and OUT/parameters.md
(calibration table: value, default, source, physical range) and prints both.

Usage: python scripts/calibrate.py [--out results/calibration] [--run 20] [--pullout-trials 5] [--set a.b=v ...]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from entangle_bench import calibration
from entangle_bench.atomic import atomic_write_text
from entangle_bench.cli import main as cli
from entangle_bench.errors import EntangleBenchError
from entangle_bench.results import markdown, read_results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/calibration"))
    parser.add_argument("--run", type=int, default=0, metavar="N", help="run N trials per condition first")
    parser.add_argument("--pullout-trials", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")
    args = parser.parse_args()
    settings = [*calibration.candidate_overrides(), *args.overrides]
    if args.run:
        for command in calibration.run_commands(args.out, args.run, args.pullout_trials, args.workers,
                                                args.overrides):
            if code := cli(command):
                return code  # the pull-out does not run after a failed calibration run
    log = args.out / "trials.jsonl"  # the log holds every finished trial, also of a run stopped early
    try:
        trials = read_results(log if log.exists() else args.out)
    except EntangleBenchError as exc:
        print(f"calibrate: error: {exc}", file=sys.stderr)
        return 2
    pullout, midair = (pd.read_csv(path) if (path := args.out / folder / "pullout.csv").exists() else None
                       for folder in ("pullout", "pullout_midair"))
    targets = markdown(calibration.target_table(trials, pullout, midair))
    parameters = markdown(calibration.candidate_parameters(settings))
    atomic_write_text(args.out / "targets.md", f"# Calibration targets ({args.out})\n\n{targets}\n")
    atomic_write_text(args.out / "parameters.md", f"# Calibration parameters ({args.out})\n\n{parameters}\n")
    print(targets, parameters, sep="\n\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
