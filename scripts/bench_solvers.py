"""Benchmark: MuJoCo's constraint solvers on one grasp state (cost per step, iterations, convergence).

Runs one trial (default: the tree; `--task`, `--preset`, `--seed`, `--set` overrides, e.g. the
`calibration` suite's settings) to `--at` seconds, saves the state, then steps `--steps` physics steps from
that same state once per solver variant and prints a markdown table: ms per step, mean constraint islands (0:
islands off), mean iterations summed over the islands, the worst island's last relative improvement (MuJoCo's
`mjData.solver`; small means converged), mean awake kinematic trees (sleeping variants), deepest contact, and how
far the variant's joint positions drift from the first variant's at the end (the trial is chaotic, so this
is a scale, not an error).

Usage: python scripts/bench_solvers.py [--task eight_branch_tree] [--preset balanced] [--set a.b=v ...] [--seed 0]
                                      [--at 2.9] [--steps 300] [--variant NAME ...]
"""

from __future__ import annotations

import argparse
import platform
import time
from typing import Any

import mujoco
import numpy as np

from entangle_bench.studies.branching import SavedTrial, option_variants, run_until
from entangle_bench.studies.profile import solver_load
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments

SLEEP = {"enableflags": lambda flags: flags | int(mujoco.mjtEnableBit.mjENBL_SLEEP)}  # MuJoCo's island sleeping

#: Variants: name -> mjOption fields changed from the configuration's own numerics (a value or a function of it).
VARIANTS: dict[str, dict[str, Any]] = {
    "configured": {},
    "configured, islands off": {"disableflags": lambda flags: flags | int(mujoco.mjtDisableBit.mjDSBL_ISLAND)},
    "configured, line search 5 iterations": {"ls_iterations": 5},
    "configured, line-search tolerance 0.1": {"ls_tolerance": 0.1},
    "cg, 10 iterations": {"solver": mujoco.mjtSolver.mjSOL_CG, "iterations": 10},
    "cg, 100 iterations": {"solver": mujoco.mjtSolver.mjSOL_CG, "iterations": 100},
    "pgs, 30 iterations": {"solver": mujoco.mjtSolver.mjSOL_PGS, "iterations": 30},
    "pgs, 100 iterations": {"solver": mujoco.mjtSolver.mjSOL_PGS, "iterations": 100},
    "configured + noslip 10": {"noslip_iterations": 10},
    "pgs, 30 iterations + noslip 10": {"solver": mujoco.mjtSolver.mjSOL_PGS, "iterations": 30, "noslip_iterations": 10},
    "newton, 5 iterations": {"solver": mujoco.mjtSolver.mjSOL_NEWTON, "iterations": 5},
    "newton, 30 iterations": {"solver": mujoco.mjtSolver.mjSOL_NEWTON, "iterations": 30},
    "configured, sleeping": SLEEP,
    "configured, sleeping at tolerance 1e-2": SLEEP | {"sleep_tolerance": 1e-2},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--at", type=float, default=2.9, help="simulated time of the state, s")
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--variant", dest="variants", action="append", metavar="NAME",
                        help="run this variant (repeatable; default: all); the first is the drift's reference")
    args = parser.parse_args()
    names = args.variants or list(VARIANTS)
    unknown = [name for name in names if name not in VARIANTS]
    if unknown:
        parser.error(f"unknown variant(s) {unknown}; choose from {list(VARIANTS)}")
    task, config = trial_from_arguments(args)
    env, _ = run_until(task, config, args.seed, lambda env: env.physics.time() >= args.at)
    physics = env.physics
    model, data = physics.model.ptr, physics.data.ptr
    saved = SavedTrial.take(env)
    print(f"machine: {platform.machine()} python {platform.python_version()} mujoco {mujoco.__version__}; "
          f"{task} preset {args.preset} seed {args.seed} {' '.join(args.overrides)}")
    print(f"state at t = {physics.time():.3f} s ({env.task.phase(physics)}): nv {model.nv}, {data.ncon} contacts, "
          f"{data.nefc} constraint rows; timestep {model.opt.timestep * 1e3:g} ms; {args.steps} steps each")
    print(f"| solver | ms per step | islands | iterations (all islands) | last improvement (worst island) "
          f"| awake trees (of {model.ntree}) | deepest contact (mm) | drift (rad) |")
    print("|---|---|---|---|---|---|---|---|")
    reference = None
    for name in option_variants(model, {name: VARIANTS[name] for name in names}):
        saved.restore(env)
        iterations, islands, awake, deepest = 0, 0, 0, 0.0
        start = time.perf_counter()
        for _ in range(args.steps):
            mujoco.mj_step(model, data)
            iterations += solver_load(data)[0]
            islands += int(data.nisland)
            awake += int(data.ntree_awake)
            if data.ncon:
                deepest = max(deepest, -float(data.contact.dist[: data.ncon].min()))
        wall = time.perf_counter() - start
        last = solver_load(data)[1]
        reference = data.qpos.copy() if reference is None else reference
        print(f"| {name} | {1e3 * wall / args.steps:.2f} | {islands / args.steps:.1f} | {iterations / args.steps:.1f} "
              f"| {last:.1e} | {awake / args.steps:.1f} | "
              f"{1e3 * deepest:.2f} | {np.abs(data.qpos - reference).max():.2f} |", flush=True)


if __name__ == "__main__":
    main()
