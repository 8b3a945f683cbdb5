"""`entangle-bench run SUITE|TASK`: seeded top-drape trials, resumable, with a summary table and plot."""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from entangle_bench import suites
from entangle_bench.errors import UnknownNameError
from entangle_bench.metrics.stats import success_table
from entangle_bench.plots import plot_success_vs
from entangle_bench.presets import DEFAULT_PRESET, PRESETS
from entangle_bench.results import TrialLog, atomic_write_csv, write_trials
from entangle_bench.runner import TrialSpec, make_executor, run_trials
from entangle_bench.stability import envelope_warnings
from entangle_bench.suite import TASKS, resolve_config


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
                   help="record every trial as MCAP under OUT/recordings (Foxglove-viewable)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(run=run)


def task_specs(args: argparse.Namespace) -> list[TrialSpec]:
    """Specs for a single task over the requested offsets."""
    task = TASKS.get(args.target).full_name
    offsets = [None] if args.offsets is None else [float(x) for x in args.offsets.split(",")]
    preset = args.preset or DEFAULT_PRESET
    specs = []
    for offset in offsets:
        config = resolve_config(task, preset, args.overrides, offset)
        label = f"{task.split('/')[-1]} offset_m={config.offset_m}"
        for k in range(args.trials or 1):
            specs.append(TrialSpec(task, label, config, args.seed + k, preset,
                                   (("param.offset_m", config.offset_m),)))
    return specs


def run(args: argparse.Namespace) -> int:
    """Run, append rows, print and save the summary."""
    try:
        header, specs = suites.load_suite(args.target, args.trials)
        if args.overrides or args.preset or args.offsets:
            print("note: --set/--preset/--offsets apply to single-task runs; the suite file fixes them")
    except UnknownNameError as suite_error:
        try:
            specs = task_specs(args)
        except UnknownNameError as task_error:
            raise UnknownNameError(
                "suite or task", args.target, suite_error.known + task_error.known
            ) from None
        header = {"name": args.target.replace("/", "_"), "description": "", "sweep": ["offset_m"]}
    out = args.out or Path("results") / header["name"]
    log = TrialLog(out / "trials.jsonl")
    print(f"{header['name']}: {len(specs)} trials -> {out}")
    for text in dict.fromkeys(w for spec in specs for w in envelope_warnings(spec.config)):
        print(f"warning: {text}")
    run_trials(
        specs, log, make_executor(args.workers), args.retry_unstable, not args.no_progress, args.record
    )
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
