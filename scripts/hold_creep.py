"""Does a held grasp creep? One trial to its hold, then the hold from that same state without and with noslip.

With `--outcomes`, instead continue the whole rest of the trial from the start of the lift once per variant
and print the task's outcome, rise, tilt and support per variant (does removing creep save the grasp?).

Runs one top-drape trial (`--task`, `--preset`, `--seed`, `--set` overrides, e.g. the `calibration` suite's
settings) until its hold begins and continues the hold `--hold` seconds once per variant: the configured
solver, then with each `--noslip` iteration count. Prints per variant the object's lowest point at the start
and end (mm), its sink rate over the second half (mm/s), when it fell below the success margin, the end tilt
and the deepest contact; `--out` also writes the per-step series as CSV and a plot beside it (.png).

Usage: python scripts/hold_creep.py [--set a.b=v ...] [--seed 0] [--hold 10] [--noslip 10,50] [--out creep.csv]
       python scripts/hold_creep.py [--set a.b=v ...] [--seed 0] --outcomes [--noslip 10]
"""

from __future__ import annotations

import argparse
import platform
from pathlib import Path

import mujoco

from entangle_bench.plots import plot_hold_creep
from entangle_bench.results import atomic_write_csv
from entangle_bench.studies.hold_creep import branch_outcomes, hold_branches
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--hold", type=float, default=10.0, help="hold continued per variant, s")
    parser.add_argument("--noslip", default="10", help="comma-separated noslip iteration counts")
    parser.add_argument("--out", type=Path, default=None, help="CSV of the per-step series")
    parser.add_argument("--outcomes", action="store_true", help="continue the whole trial from the lift instead")
    args = parser.parse_args()
    task, config = trial_from_arguments(args)
    variants = {"configured": {}} | {
        f"noslip {n}": {"noslip_iterations": int(n)} for n in args.noslip.split(",") if n.strip()
    }
    if args.outcomes:
        rows = branch_outcomes(task, config, args.seed, variants, start_phase="lift")
        print(f"{task} seed {args.seed} {' '.join(args.overrides)}; from the start of the lift, per variant")
        print("| variant | outcome | rise (mm) | hold tilt (deg) | branches (W) | ground (W) | deepest (mm) "
              "| wall (s) |")
        print("|---|---|---|---|---|---|---|---|")
        for _, r in rows.iterrows():
            print(f"| {r['variant']} | {r['outcome']} {r['failure_mode'] or r['unstable_reason']} | "
                  f"{1e3 * r['lift_height_m']:.1f} | {r['max_hold_tilt_deg']:.1f} | "
                  f"{r.get('support.part.branch_w', float('nan')):.2f} | {r['support.ground_w']:.2f} | "
                  f"{1e3 * r['max_penetration_m']:.2f} | {r['wall_s']:.0f} |", flush=True)
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
