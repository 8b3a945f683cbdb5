"""`entangle-bench run SUITE|TASK`: seeded trials, resumable, with a summary table and plot."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from entangle_bench import suites
from entangle_bench.errors import UnknownNameError
from entangle_bench.executors import make_executor
from entangle_bench.metrics.stats import success_table
from entangle_bench.plots import plot_success_vs
from entangle_bench.presets import PRESETS
from entangle_bench.results import TrialLog, atomic_write_csv, write_trials
from entangle_bench.runner import Watch, run_trials
from entangle_bench.stability import envelope_warnings
from entangle_bench.suite.gripper_task import GripperTaskConfig


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Attach the `run` subcommand."""
    p = sub.add_parser("run", help="run a suite (tasks/*.toml) or a single task")
    p.add_argument("target", help="suite name (see `entangle-bench tasks`) or task name")
    p.add_argument("--trials", type=int, default=None, help="seeded trials per condition")
    p.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    p.add_argument("--out", type=Path, default=None, help="output folder (default results/TARGET)")
    p.add_argument("--preset", choices=sorted(PRESETS), default=None, help="numerical preset")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE",
                   help="override a config field, e.g. phases.hold_time_s=1 (repeatable)")
    p.add_argument("--offsets", default=None, help="task runs only: comma-separated offsets in m")
    p.add_argument("--seed", type=int, default=0, help="first seed")
    p.add_argument("--retry-unstable", action="store_true", help="rerun unstable trials at dt/2")
    p.add_argument("--record", action="store_true",
                   help="record every trial as a Foxglove MCAP file under OUT/recordings")
    p.add_argument("--video", action="store_true", help="write every trial as an MP4 under OUT/videos (headless)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run, append rows, print and save the summary."""
    try:
        suite = suites.load_suite(args.target, args.trials)
        if args.overrides or args.preset or args.offsets:
            print("note: --set/--preset/--offsets apply to single-task runs; the suite file fixes them")
    except UnknownNameError as suite_error:
        offsets = None if args.offsets is None else [float(x) for x in args.offsets.split(",")]
        try:
            suite = suites.task_suite(
                args.target,
                preset=args.preset,
                overrides=args.overrides,
                offsets=offsets,
                trials=args.trials or 1,
                seed=args.seed,
            )
        except UnknownNameError as task_error:
            raise UnknownNameError(
                "suite or task", args.target, suite_error.known + task_error.known
            ) from None
    specs = list(suite.specs)
    out = args.out or Path("results") / suite.name
    log = TrialLog(out / "trials.jsonl")
    print(f"{suite.name}: {len(specs)} trials -> {out}")
    gripper_configs = [spec.config for spec in specs if isinstance(spec.config, GripperTaskConfig)]
    for text in dict.fromkeys(w for config in gripper_configs for w in envelope_warnings(config)):
        print(f"warning: {text}")
    run_trials(specs, log, make_executor(args.workers), retry_unstable=args.retry_unstable,
               progress=not args.no_progress, watch=Watch(record=args.record, video=args.video))
    rows = log.frame()
    wanted = {s.trial_id for s in specs}
    rows = rows[rows["trial_id"].isin(wanted)]
    write_trials(rows, out)
    params = [c for c in rows.columns if c.startswith("param.")]
    summary = success_table(rows, ["condition"])
    atomic_write_csv(summary, out / "summary.csv")
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    if "param.offset_m" in params and rows["param.offset_m"].nunique() > 1:
        path = plot_success_vs(rows, "param.offset_m", out / "success_vs_offset.png")
        print(f"plot: {path}")
    for column in params:
        if column != "param.offset_m" and rows[column].nunique() > 1:
            path = plot_success_vs(rows, column, out / f"success_vs_{column.removeprefix('param.')}.png")
            print(f"plot: {path}")
    print(f"rows: {out / 'trials.csv'}  summary: {out / 'summary.csv'}")
    return 0
