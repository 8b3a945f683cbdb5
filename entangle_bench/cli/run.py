"""`entangle-bench run SUITE|TASK`: seeded trials, resumable, with a summary table and plot.

The rows, summary and plots cover every seed of the run's conditions the output folder's log holds, so a run
that adds seeds to a folder summarizes them all.

Everything the command line asks for is checked before any trial simulates: numbers and lists, the suite or
task, every condition's configuration, the output folder (created and written to), the executor. Pull-out
trials add the pull-out summary `pullout.csv` and its figures (`entangle_bench.pullout.write_report`).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from entangle_bench import suites
from entangle_bench.atomic import AtomicFile
from entangle_bench.cli.interrupt import Interrupted
from entangle_bench.cli.report import write_outputs
from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.executors import EXECUTORS, make_executor
from entangle_bench.presets import PRESETS
from entangle_bench.results import LOG_NAME, TrialLog
from entangle_bench.runner import TrialSpec, Watch, run_trials, trial_id
from entangle_bench.stability import envelope_warnings
from entangle_bench.suite.gripper_task import GripperTaskConfig


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Attach the `run` subcommand."""
    p = sub.add_parser("run", help="run a suite (tasks/*.toml) or a single task")
    p.add_argument("target", help="suite name (see `entangle-bench tasks`), suite file (.toml) or task name")
    p.add_argument("--trials", default=None, metavar="N",
                   help="seeded trials per condition (default: the suite's, 1 for a task)")
    p.add_argument("--workers", default="2", metavar="N",
                   help="local worker processes, or the CPUs of a new local Ray instance (default 2)")
    p.add_argument("--executor", default="local", metavar="KIND",
                   help=f"where trials run: {' or '.join(EXECUTORS)} (default local)")
    p.add_argument("--address", default=None, metavar="ADDR",
                   help="with --executor ray: an existing Ray cluster ('auto', HOST:PORT or ray://HOST:PORT); "
                        "default: RAY_ADDRESS if set, else a new local Ray instance")
    p.add_argument("--out", type=Path, default=None, help="output folder (default results/TARGET)")
    p.add_argument("--preset", default=None, metavar="NAME",
                   help=f"numerical preset: {', '.join(sorted(PRESETS))} (on a suite: replaces the file's)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="PATH=VALUE",
                   help="override a config field, e.g. phases.hold_time_s=1 (repeatable; on a suite: every "
                        "condition)")
    p.add_argument("--offsets", default=None, metavar="M,M,...",
                   help="comma-separated centering offsets in m (on a suite: replaces its offset_m sweep)")
    p.add_argument("--seed", default=None, metavar="N", help="first seed, a non-negative integer (default: the "
                                                             "suite's, 0 for a task)")
    p.add_argument("--retry-unstable", action="store_true",
                   help="rerun unstable trials at dt/2, also those a previous run logged as unstable")
    p.add_argument("--record", action="store_true",
                   help="record every trial as a Foxglove MCAP file under OUT/recordings")
    p.add_argument("--video", action="store_true", help="write every trial as an MP4 under OUT/videos (headless)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(run=run)


def _integer(option: str, text: str | None, minimum: int) -> int | None:
    """`text` as an integer of at least `minimum`, or None; ParameterError naming the option otherwise."""
    if text is None:
        return None
    try:
        value = int(text)
    except ValueError:
        value = None
    if value is None or value < minimum:
        allowed = "a positive integer" if minimum == 1 else "a non-negative integer"
        raise ParameterError(f"{option} {text!r}: must be {allowed}")
    return value


def _offsets(text: str | None) -> list[float] | None:
    """Comma-separated offsets (m) as floats; ParameterError naming the bad item otherwise."""
    if text is None:
        return None
    values = []
    for item in text.split(","):
        try:
            value = float(item)
        except ValueError:
            value = math.nan
        if not math.isfinite(value) or value < 0:
            raise ParameterError(f"--offsets {text!r}: {item.strip()!r} is not an offset; expected comma-separated "
                                 "non-negative numbers in m, e.g. 0,0.01,0.02")
        values.append(value)
    return values


def _check_output_folder(out: Path) -> None:
    """Create `out` and write a file into it, so an unusable output folder fails before any trial runs."""
    if out.exists() and not out.is_dir():
        raise ParameterError(f"--out {out}: is a file, not a folder; give a folder (it is created if missing)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        with AtomicFile(out / ".write-test") as probe:
            probe.tmp.write_bytes(b"")
        (out / ".write-test").unlink()
    except OSError as exc:
        raise ParameterError(f"output folder {out} cannot be written ({exc.strerror or exc}); choose another "
                             "with --out") from None


def _suite(args: argparse.Namespace) -> suites.Suite:
    """The suite file or single task named by `target`, with the command-line settings applied."""
    trials = _integer("--trials", args.trials, 1)
    seed = _integer("--seed", args.seed, 0)
    offsets = _offsets(args.offsets)
    if args.preset is not None and args.preset not in PRESETS:
        raise UnknownNameError("preset", args.preset, PRESETS.names())
    try:
        return suites.load_suite(args.target, trials, preset=args.preset, overrides=args.overrides,
                                 offsets=offsets, seed=seed)
    except UnknownNameError as suite_error:
        if suite_error.kind != "suite":
            raise
        try:
            return suites.task_suite(args.target, preset=args.preset, overrides=args.overrides, offsets=offsets,
                                     trials=trials or 1, seed=seed or 0)
        except UnknownNameError as task_error:
            if task_error.kind != "task":
                raise
            raise UnknownNameError("suite or task", args.target, suite_error.known + task_error.known) from None


def _suite_ids(specs: list[TrialSpec], seeds: set[int]) -> set[str]:
    """Trial ids of the specs' conditions at every seed in `seeds`: the rows of this suite a log holds,
    those of earlier runs with other seeds included."""
    conditions = {trial_id(s.task, s.config, 0): (s.task, s.config) for s in specs}.values()  # one per condition
    return {trial_id(task, config, seed) for task, config in conditions for seed in seeds}


def run(args: argparse.Namespace) -> int:
    """Check the inputs, run the missing trials, append rows, print and save the summary."""
    workers = _integer("--workers", args.workers, 1)
    executor = make_executor(workers, args.executor, args.address)
    suite = _suite(args)
    specs = list(suite.specs)
    out = args.out or Path("results") / suite.name
    _check_output_folder(out)
    log = TrialLog(out / LOG_NAME)
    print(f"{suite.name}: {len(specs)} trials -> {out}")
    gripper_configs = [spec.config for spec in specs if isinstance(spec.config, GripperTaskConfig)]
    for text in dict.fromkeys(w for config in gripper_configs for w in envelope_warnings(config)):
        print(f"warning: {text}")
    try:
        run_trials(specs, log, executor, retry_unstable=args.retry_unstable, progress=not args.no_progress,
                   watch=Watch(record=args.record, video=args.video))
    except (KeyboardInterrupt, Interrupted):
        done = len(log.done_ids(args.retry_unstable) & {s.trial_id for s in specs})
        print(f"entangle-bench: run interrupted: {done} of {len(specs)} trials are in {log.path}; "
              "rerun the same command to run the others", file=sys.stderr)
        raise
    rows = log.frame()
    rows = rows[rows["trial_id"].isin(_suite_ids(specs, {int(seed) for seed in rows["seed"].dropna()}))]
    code = write_outputs(rows, out)
    print(f"rows: {out / 'trials.csv'}  summary: {out / 'summary.csv'}"
          + (f" (every seed of these conditions in the log: {len(rows)} trials)" if len(rows) > len(specs) else ""))
    return code
