"""Screen gripper variants by how their coils catch the object at the start of the lift.

Runs each variant's trials (`--seed` and the next `--seeds - 1` seeds) through the approach, actuation and
settle only (`entangle_bench.studies.catch`), and prints per variant the mean filament–object contacts, the
filament self-contacts (a coil lying on itself catches nothing), the filaments touching the object and their
normal force on it, with the paired difference of each seed against the first variant. `--rows FILE ...`
first prints how success follows those contacts in finished trials.

Usage: python scripts/screen_catch.py [--task eight_branch_tree] [--preset balanced] [--set a.b=v ...]
           [--variant NAME:a.b=v,c.d=w ...] [--seed 0] [--seeds 4] [--out screen.csv] [--states DIR]
           [--rows trials.jsonl ...]
"""

from __future__ import annotations

import argparse
import platform
from pathlib import Path

import mujoco
import pandas as pd

from entangle_bench.atomic import atomic_write_text
from entangle_bench.errors import ParameterError
from entangle_bench.results import markdown
from entangle_bench.studies.catch import catch_outcome_table, parse_variant, screen, screen_table
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--variant", action="append", default=[], metavar="NAME:a.b=v,...",
                        help="a variant (repeatable); the first is the baseline (default: one, 'configured')")
    parser.add_argument("--seeds", type=int, default=4,
                        help="trials per variant, seeds --seed, --seed + 1, ... (0: only tabulate --rows)")
    parser.add_argument("--out", type=Path, help="write the rows as CSV")
    parser.add_argument("--states", type=Path, help="save each snapshot as DIR/<variant>_seed<S>_actuated.npz "
                        "(draw it with scripts/plot_entanglement.py)")
    parser.add_argument("--rows", type=Path, nargs="*", default=[], help="finished trial rows (jsonl) to tabulate")
    args = parser.parse_args()
    if args.seeds < 0:
        raise ParameterError(f"--seeds must be at least 0 (0: only tabulate --rows), got {args.seeds}")
    task, config = trial_from_arguments(args)  # checks the task, preset and --set before anything runs
    if args.rows:
        done = pd.concat([pd.read_json(path, lines=True) for path in args.rows], ignore_index=True)
        done = done[(done["task"] == task) & ((done["config.offset_m"] - config.offset_m).abs() < 1e-9)]
        print(f"Success by filament–object contacts at the start of the lift, finished {task} trials at "
              f"offset {config.offset_m:g} m:")
        print(markdown(catch_outcome_table(done), digits=2), "\n")
    if not args.seeds:
        return
    variants = dict(parse_variant(v) for v in args.variant) or {"configured": []}
    seeds = range(args.seed, args.seed + args.seeds)
    print(f"machine: {platform.machine()} mujoco {mujoco.__version__}; {task} preset {args.preset} seeds "
          f"{seeds.start}–{seeds.stop - 1} {' '.join(args.overrides)}")
    rows = screen(task, args.preset, variants, seeds, args.overrides, args.states)
    if args.out:
        atomic_write_text(args.out, rows.to_csv(index=False))
    print("| variant | stable / run | filament–object contacts | filament self-contacts | filaments touching "
          "| normal force on the object (N) | paired difference in contacts | wall per trial (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for line in screen_table(rows).itertuples():
        print(f"| {line.variant} | {line.stable} / {line.run} | {line.contacts_mean:.1f} ± {line.contacts_std:.1f} | "
              f"{line.self_contacts_mean:.0f} | {line.filaments_touching_mean:.1f} | {line.normal_force_mean_n:.3f} | "
              f"{line.paired_contacts_diff:+.1f} ({line.paired_seeds} seeds) | {line.wall_mean_s:.0f} |")
    for line in rows[rows["unstable"] != ""].itertuples():
        print(f"unstable: {line.variant} seed {line.seed}: {line.unstable}")


if __name__ == "__main__":
    main()
