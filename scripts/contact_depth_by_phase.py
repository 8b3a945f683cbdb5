"""Does a grasp lean on penetration? Deepest contact and deep-contact load share per phase of one trial.

Runs one top-drape trial (preset, `--set` overrides, seed) under an observer and prints, per task phase, the
deepest contact (mm, with the geom pair and time) and the share of the filament–object normal force that
contacts deeper than `--deep` (default: the filament radius) carry, summed over the control steps.
A hold carried by embedded filaments would show a large share in `hold`.

Usage: python scripts/contact_depth_by_phase.py [--task eight_branch_tree] [--preset balanced] [--seed 0]
                                               [--set a.b=v ...] [--deep 0.001]
"""

from __future__ import annotations

import argparse
import platform

import mujoco

from entangle_bench.studies.contact_depth import contact_depth_by_phase
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--deep", type=float, default=None, help="depth counted as deep, m (default: filament radius)")
    args = parser.parse_args()
    task, config = trial_from_arguments(args)
    deep = args.deep if args.deep is not None else config.gripper.filament.outer_radius_m
    result, table = contact_depth_by_phase(task, config, args.seed, deep)
    row = result.row
    print(f"machine: {platform.machine()} mujoco {mujoco.__version__}; {task} preset {args.preset} seed {args.seed} "
          f"{' '.join(args.overrides)}")
    print(f"outcome: {row['outcome']} {row.get('failure_mode') or row.get('unstable_reason') or ''}; "
          f"deepest after the grace time {1e3 * row['max_penetration_m']:.2f} mm")
    print(f"| phase | deepest contact (mm) | where | filament–object normal force deeper than {1e3 * deep:g} mm |")
    print("|---|---|---|---|")
    for _, phase in table.iterrows():
        print(f"| {phase['phase']} | {1e3 * phase['deepest_m']:.2f} | {phase['where']} | "
              f"{100 * phase['deep_share']:.1f} % |")


if __name__ == "__main__":
    main()
