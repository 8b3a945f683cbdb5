"""Benchmark: wall time per trial of the default tree task and trials per hour with 1 and 2 workers (`--workers`).

Runs N seeded default trials (balanced preset unless --preset; `--set a.b=v` overrides, e.g. the
`calibration` suite's settings) into a scratch log and prints a markdown table.
Usage: python scripts/bench_trials.py [--trials 4] [--preset balanced] [--set a.b=v ...] [--workers 1,2]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time
from pathlib import Path

import mujoco

from entangle_bench.executors import make_executor
from entangle_bench.results import TrialLog
from entangle_bench.runner import TrialSpec, run_trials
from entangle_bench.suite import resolve_config


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--trials", type=int, default=4)
    parser.add_argument("--preset", default="balanced")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE")
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts to time (default 1,2)")
    args = parser.parse_args()
    bad = f"--workers {args.workers!r}: expected comma-separated positive integers, e.g. 1,2"
    try:
        worker_counts = [int(w) for w in args.workers.split(",")]
    except ValueError:
        parser.error(bad)
    if min(worker_counts) < 1:
        parser.error(bad)
    config = resolve_config("eight_branch_tree", args.preset, args.overrides)
    print(f"machine: {platform.machine()} python {platform.python_version()} mujoco {mujoco.__version__}; "
          f"default eight_branch_tree trial, preset {args.preset} {' '.join(args.overrides)}")
    print("| workers | trials | wall (s) | mean wall per trial (s) | sim time per trial (s) | real-time factor "
          "| trials per hour |")
    print("|---|---|---|---|---|---|---|")
    for workers in worker_counts:
        specs = [
            TrialSpec("top_drape/eight_branch_tree", "tree", config, 1000 * workers + k, args.preset)
            for k in range(args.trials)
        ]
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            rows = run_trials(specs, TrialLog(Path(tmp) / "t.jsonl"), make_executor(workers), progress=False)
            wall = time.perf_counter() - start
        per_trial = statistics.mean(r["wall_time_s"] for r in rows)
        sim = statistics.mean(r["sim_time_s"] for r in rows)
        print(f"| {workers} | {len(rows)} | {wall:.1f} | {per_trial:.1f} | {sim:.2f} | {sim / per_trial:.2f} | "
              f"{3600 * len(rows) / wall:.0f} |", flush=True)


if __name__ == "__main__":
    main()
