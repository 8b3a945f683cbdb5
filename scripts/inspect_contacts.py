"""What happened before a trial went unstable? The deepest contact of every control step in a time window.

Runs one trial (task, preset, seed, `--set` overrides) with its scripted policy to `--from` seconds, then
prints for every control step up to `--to` the deepest contact: depth (mm), the geom pair, its normal force
(N) and tangential (friction) force (N), and the hub height (m). An `unstable` row names a penetration and
a time; this shows the contact building up to it, e.g. a filament wedged in a branch crotch with newtons of
normal force, where a filament weighs 8 mN.

Usage: python scripts/inspect_contacts.py --from 1.7 --to 2.0 [--task eight_branch_tree] [--preset balanced]
                                          [--seed 0] [--set a.b=v ...] [--min-depth 0]
"""

from __future__ import annotations

import argparse
import platform

import mujoco
import numpy as np

from entangle_bench.studies.branching import run_until
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--from", dest="start", type=float, required=True, help="start of the window, s")
    parser.add_argument("--to", dest="end", type=float, required=True, help="end of the window, s")
    parser.add_argument("--min-depth", type=float, default=0.0, help="print only contacts deeper than this, m")
    args = parser.parse_args()
    task, config = trial_from_arguments(args)
    env, ended = run_until(task, config, args.seed, lambda env: env.physics.time() >= args.start)
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    print(f"machine: {platform.machine()} mujoco {mujoco.__version__}; {task} preset {args.preset} seed {args.seed} "
          f"{' '.join(args.overrides)}")
    print("| t (s) | phase | depth (mm) | geoms | normal force (N) | friction force (N) | hub z (m) |")
    print("|---|---|---|---|---|---|---|")
    wrench = np.zeros(6)
    time_step = None
    while not ended and physics.time() < args.end and not (time_step is not None and time_step.last()):
        time_step = env.step(env.task.scripted_action(physics))
        if not data.ncon:
            continue
        i = int(np.argmin(data.contact.dist[: data.ncon]))
        contact = data.contact[i]
        if -contact.dist <= args.min_depth:
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        pair = f"{model.geom(contact.geom1).name} / {model.geom(contact.geom2).name}"
        print(f"| {physics.time():.3f} | {env.task.phase(physics)} | {-1e3 * contact.dist:.2f} | {pair} | "
              f"{wrench[0]:.4f} | {np.hypot(wrench[1], wrench[2]):.4f} | {data.mocap_pos[0, 2]:.4f} |")


if __name__ == "__main__":
    main()
