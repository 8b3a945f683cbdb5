"""Does a held grasp creep? One trial to its hold, then the hold from that same state without and with noslip.

With `--outcomes`, instead continue the whole rest of the trial from the start of the lift once per variant
and print the task's outcome, clearance, tilt and support per variant (does removing creep save the grasp? does a
trial that went unstable in the lift survive it with impratio only from the hold?).

Variants: the configured solver, one per `--noslip` iteration count and one per `--vary` (space-separated
PATH=VALUE: mjOption fields, or the config fields the task reads at every step, e.g.
`--vary "numerics.impratio_phases=hold,release"`).

Runs one top-drape trial (`--task`, `--preset`, `--seed`, `--set` overrides, e.g. the `calibration` suite's
settings) until its hold begins and continues the hold `--hold` seconds once per variant: the configured
solver, then with each `--noslip` iteration count. Prints per variant the object's lowest point at the start
and end (mm), its sink rate over the second half (mm/s), when it fell below the success margin, the end tilt
and the deepest contact; `--out` also writes the per-step series as CSV and a plot beside it (.png).

Usage: python scripts/hold_creep.py [--set a.b=v ...] [--seed 0] [--hold 10] [--noslip 10,50] [--out creep.csv]
       python scripts/hold_creep.py [--set a.b=v ...] [--seed 0] --outcomes [--noslip 10] [--vary "a.b=v ..." ...]
"""

from __future__ import annotations

import argparse
import platform
from pathlib import Path

import mujoco
import pandas as pd

from entangle_bench.plots import plot_hold_creep
from entangle_bench.results import atomic_write_csv
from entangle_bench.studies.hold_creep import branch_outcomes, hold_branches
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def _changes(text: str) -> dict[str, object]:
    """A `--vary` text's changes: config paths keep their text, mjOption fields become numbers."""
    changes: dict[str, object] = {}
    for item in text.split():
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--vary {text!r}: {item!r} must look like PATH=VALUE")
        if "." in key:
            changes[key] = value
            continue
        try:
            changes[key] = int(value) if value.lstrip("-").isdigit() else float(value)
        except ValueError:
            raise SystemExit(f"--vary {text!r}: mjOption field {key} needs a number, got {value!r}") from None
    return changes


#: `--outcomes` table columns after the outcome: row key, scale, decimals (a trial stopped before the hold has
#: no support shares: printed as "-").
_OUTCOME_COLUMNS = (
    ("end_time_s", 1.0, 2), ("lift_clearance_m", 1e3, 1), ("max_hold_tilt_deg", 1.0, 1),
    ("support.part.branch_w", 1.0, 2), ("support.ground_w", 1.0, 2), ("max_penetration_m", 1e3, 2),
    ("wall_s", 1.0, 0),
)


def _cell(row: pd.Series, key: str, scale: float, digits: int) -> str:
    """One table cell: the row's value times `scale`, or "-" where the row lacks it."""
    value = row.get(key)
    return "-" if value is None or value != value else f"{scale * value:.{digits}f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--hold", type=float, default=10.0, help="hold continued per variant, s")
    parser.add_argument("--noslip", default="10", help="comma-separated noslip iteration counts")
    parser.add_argument("--out", type=Path, default=None, help="CSV of the per-step series")
    parser.add_argument("--outcomes", action="store_true", help="continue the whole trial from the lift instead")
    parser.add_argument("--vary", action="append", default=[], metavar='"PATH=VALUE ..."',
                        help="one more variant: mjOption fields or numerics.impratio(_phases)/noslip_iterations/"
                             "noslip_phases")
    args = parser.parse_args()
    task, config = trial_from_arguments(args)
    variants = {"configured": {}} | {
        f"noslip {n}": {"noslip_iterations": int(n)} for n in args.noslip.split(",") if n.strip()
    } | {text: _changes(text) for text in args.vary}
    if args.outcomes:
        rows = branch_outcomes(task, config, args.seed, variants, start_phase="lift")
        print(f"{task} seed {args.seed} {' '.join(args.overrides)}; from the start of the lift, per variant")
        print("| variant | outcome | ended (s) | clearance (mm) | hold tilt (deg) | branches (W) | ground (W) "
              "| deepest (mm) | wall (s) |")
        print("|---|---|---|---|---|---|---|---|---|")
        for _, r in rows.iterrows():
            cells = [_cell(r, key, scale, digits) for key, scale, digits in _OUTCOME_COLUMNS]
            print(f"| {r['variant']} | {r['outcome']} {r['failure_mode'] or r['unstable_reason']} | "
                  f"{' | '.join(cells)} |", flush=True)
        return
    summary, series = hold_branches(task, config, args.seed, variants, args.hold)
    print(f"machine: {platform.machine()} mujoco {mujoco.__version__}; {task} preset {args.preset} seed {args.seed} "
          f"{' '.join(args.overrides)}; hold {args.hold:g} s per variant from the same state")
    print("| variant | lowest point at start (mm) | at end (mm) | sink rate, 2nd half (mm/s) | below margin at (s) "
          "| end tilt (deg) | deepest contact (mm) | wall (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for _, r in summary.iterrows():
        print(f"| {r['variant']} | {1e3 * r['start_low_m']:.1f} | {1e3 * r['end_low_m']:.1f} | "
              f"{1e3 * r['sink_rate_m_s']:.3f} | {r['below_margin_at_s']:.2f} | {r['end_tilt_deg']:.1f} | "
              f"{1e3 * r['deepest_contact_m']:.2f} | {r['wall_s']:.0f} |")
    if args.out is not None:
        atomic_write_csv(series, args.out)
        plot_hold_creep(series, args.out.with_suffix(".png"), config.success_margin_m)


if __name__ == "__main__":
    main()
