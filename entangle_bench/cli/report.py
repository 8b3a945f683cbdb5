"""`entangle-bench report FOLDER`: rewrite a results folder's tables and plots from its whole log.

A `run` writes the rows, summary and plots of its own conditions only; a folder that several runs filled (task
runs label a condition `NAME offset_m=X`, suite runs `NAME`; other settings, other steps) is summarized whole
by this command, grouped by the log's `condition` or by any config or parameter columns (`--by`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from entangle_bench.errors import FileFormatError, ParameterError
from entangle_bench.metrics.stats import success_table
from entangle_bench.plots import plot_success_vs
from entangle_bench.pullout import write_report
from entangle_bench.results import FAILED, LOG_NAME, TrialLog, atomic_write_csv, write_trials


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Attach the `report` subcommand."""
    p = sub.add_parser("report", help="rewrite a results folder's tables and plots from its whole trial log")
    p.add_argument("folder", type=Path, help=f"results folder holding {LOG_NAME}")
    p.add_argument("--by", default="condition", metavar="COLUMN[,COLUMN]",
                   help="group rows by these columns instead of the logged condition, e.g. config.object_name "
                        "(allowed: condition, task, config.* and param.* columns of the log)")
    p.set_defaults(run=run)


def regroup(rows: pd.DataFrame, by: str) -> pd.DataFrame:
    """`rows` with `condition` relabelled to the values of the comma-separated columns `by`; ParameterError
    naming the unknown column and the allowed ones otherwise."""
    columns = [c.strip() for c in by.split(",") if c.strip()]
    allowed = [c for c in rows.columns if c in ("condition", "task") or c.startswith(("config.", "param."))]
    unknown = [c for c in columns if c not in allowed]
    if not columns or unknown:
        examples = ", ".join(c for c in allowed if c == "config.object_name" or c.startswith("param."))
        raise ParameterError(f"--by {by!r}: {', '.join(map(repr, unknown)) or 'no column'} is not a column of "
                             f"this log; allowed: condition, task and its config.*/param.* columns, e.g. {examples}")
    if columns == ["condition"]:
        return rows
    labels = rows[columns].astype(str).agg(" ".join, axis=1) if len(columns) > 1 else rows[columns[0]].astype(str)
    return rows.assign(condition=labels)


def write_outputs(rows: pd.DataFrame, out: Path) -> int:
    """Write `rows` (typed trial rows) into `out` as `trials.csv`/`.parquet`, `summary.csv` (success by
    condition), success plots over every varied parameter and, for pull-out rows, the pull-out report; print the
    tables; return 1 if some trial failed to run, else 0."""
    write_trials(rows, out)
    params = [c for c in rows.columns if c.startswith("param.")]
    summary = success_table(rows, ["condition"])
    atomic_write_csv(summary, out / "summary.csv")
    with pd.option_context("display.width", 160, "display.max_columns", 20):
        print(summary.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    for column in params:
        if rows[column].nunique() > 1:
            name = "offset" if column == "param.offset_m" else column.removeprefix("param.")
            path = plot_success_vs(rows, column, out / f"success_vs_{name}.png")
            print(f"plot: {path}")
    report = write_report(rows, out)
    if report:
        table = pd.read_csv(report[0])
        columns = ["condition", "scored", "released", "slid_off", "held", "peak_force_median_n",
                   "toughness_median_j", "contact_scored", "contact_toughness_median_j", "reference_toughness_j"]
        with pd.option_context("display.width", 160, "display.max_columns", 20):
            print(table[columns].to_string(index=False, float_format=lambda v: f"{v:.3g}"))
        print("pull-out: " + "  ".join(str(p) for p in report))
    failed = rows[rows["outcome"] == FAILED]
    if len(failed):
        print(f"entangle-bench: {len(failed)} trial(s) failed to run (outcome '{FAILED}', not scored; see "
              f"failed_reason in {out / 'trials.csv'}); rerun the `entangle-bench run` command that ran them to "
              f"retry them. First: "
              f"{failed['failed_reason'].iloc[0]}", file=sys.stderr)
        return 1
    return 0


def run(args: argparse.Namespace) -> int:
    """Read the folder's whole log, regroup it and rewrite the folder's tables and plots."""
    log = args.folder / LOG_NAME
    if not log.is_file():
        raise FileFormatError(f"{args.folder}: no {LOG_NAME} here; give a folder that `entangle-bench run` wrote")
    rows = TrialLog(log).frame()
    if rows.empty:
        raise FileFormatError(f"{log}: holds no finished trial")
    rows = regroup(rows, args.by)
    code = write_outputs(rows, args.folder)
    print(f"rows: {args.folder / 'trials.csv'} ({len(rows)} trials, every row of {log})  "
          f"summary: {args.folder / 'summary.csv'}")
    return code
