"""Benchmark: local parallel trials - MuJoCo 3.17's `mujoco.batch` thread pool against worker processes, and Ray.

Part 1, physics only: N copies of the default trial's model (eight_branch_tree, one per seed: the seeds' bending
planes make the models differ, as `Batch.set_models` allows) from the state 2.0 s into the trial (filaments
curling on the tree, contacts active), each stepped K times. The same steps are run

- in a Python loop over `mujoco.mj_step` (one MjData per simulation), in this process;
- in P = 1 and 2 spawned processes, N / P simulations each (timed inside the workers, without start-up);
- by `mujoco.batch.Batch(..., nthread=T)` for T = 1 and 2: in one call (`step(nstep=K)`), and one call per
  substep (`step()` K times: what the trial's per-substep Python would need);

and the final states are checked to be bit-identical.

Part 2, whole trials through the runner's executors (rows, files and watchdog as in `entangle-bench run`): M
default trials of the tree (balanced; --short: SHORT_SEQUENCE) serially, on 2 local processes, on 2 Python
threads (the runner's loop holds the GIL between MuJoCo calls), and on a local 2-CPU Ray instance (its
start-up timed apart).

Part 3, executor overhead: N trials that simulate almost nothing, serially, on one worker process and on a
one-CPU Ray instance (start-ups timed apart); the difference to the serial run is what each executor adds per
trial (dispatch, pickling, returning the row and files).

Usage: python scripts/bench_parallel.py [--part physics|trials|overhead|all] [--sims 8] [--steps 500]
       [--trials 6] [--short] [--tiny 40] [--no-ray]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import multiprocessing
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from entangle_bench.executors import ProcessExecutor, RayExecutor, SerialExecutor
from entangle_bench.results import TrialLog
from entangle_bench.runner import TrialSpec, run_trials
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config
from entangle_bench.suite.top_drape import TopDrape

TASK = "top_drape/eight_branch_tree"
STATE = mujoco.mjtState.mjSTATE_INTEGRATION


def snapshot(seed: int, time_s: float) -> tuple[mujoco.MjModel, np.ndarray]:
    """The default trial of `seed` at `time_s`: its model (pressure set) and full physics state."""
    env = TopDrape.make_environment(resolve_config(TASK), seed)
    env.reset()
    physics, task = env.physics, env.task
    while physics.time() < time_s:
        env.step(task.scripted_action(physics))
    model, data = physics.model.ptr, physics.data.ptr
    state = np.empty(mujoco.mj_stateSize(model, STATE))
    mujoco.mj_getState(model, data, state, STATE)
    return model, state


def loop(models: list[mujoco.MjModel], states: np.ndarray, steps: int) -> np.ndarray:
    """Step every simulation `steps` times in a Python loop over mj_step; return the final states."""
    out = np.empty_like(states)
    for i, (model, state) in enumerate(zip(models, states)):
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, state, STATE)
        for _ in range(steps):
            mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, out[i], STATE)
    return out


def _process_worker(args: tuple[list[int], float, int], barrier: Any) -> tuple[float, float, np.ndarray]:
    seeds, time_s, steps = args
    pairs = [snapshot(seed, time_s) for seed in seeds]
    barrier.wait()
    start, cpu = time.perf_counter(), time.process_time()
    final = loop([m for m, _ in pairs], np.array([s for _, s in pairs]), steps)
    return time.perf_counter() - start, time.process_time() - cpu, final


def processes(seeds: list[int], time_s: float, steps: int, n: int) -> tuple[float, float, np.ndarray]:
    """Wall and CPU time (s) of `n` spawned processes stepping their share of the simulations, from a barrier."""
    context = multiprocessing.get_context("spawn")
    with context.Manager() as manager:
        barrier = manager.Barrier(n)
        shares = [seeds[k::n] for k in range(n)]
        with concurrent.futures.ProcessPoolExecutor(n, mp_context=context) as pool:
            futures = [pool.submit(_process_worker, (share, time_s, steps), barrier) for share in shares]
            results = [f.result() for f in futures]
    final = np.empty((len(seeds), results[0][2].shape[1]))
    for k, (_, _, part) in enumerate(results):
        final[k::n] = part
    return max(r[0] for r in results), sum(r[1] for r in results), final


def batched(models: list[mujoco.MjModel], states: np.ndarray, steps: int, threads: int,
            per_substep: bool) -> tuple[float, float, np.ndarray]:
    """Wall and CPU time (s) of mujoco.batch stepping every simulation `steps` times on `threads` threads."""
    engine = mjbatch.Batch(models[0], nsim=len(models), nthread=threads)
    engine.set_models(models)
    engine.state[:] = states
    start, cpu = time.perf_counter(), time.process_time()
    if per_substep:
        for _ in range(steps):
            engine.step()
    else:
        engine.step(nstep=steps)
    return time.perf_counter() - start, time.process_time() - cpu, engine.state.copy()


def physics_table(args: argparse.Namespace) -> None:
    seeds = list(range(args.sims))
    pairs = [snapshot(seed, args.at) for seed in seeds]
    models, states = [m for m, _ in pairs], np.array([s for _, s in pairs])
    total = args.sims * args.steps
    start, cpu = time.perf_counter(), time.process_time()
    reference = loop(models, states, args.steps)
    rows = [("Python loop over mj_step, this process", 1, time.perf_counter() - start, time.process_time() - cpu,
             True)]
    for n in (1, 2):
        wall, used, final = processes(seeds, args.at, args.steps, n)
        rows.append((f"{n} worker process{'es' if n > 1 else ''}, loop over mj_step", n, wall, used,
                     np.array_equal(final, reference)))
    for threads in (1, 2):
        for per_substep in (False, True):
            wall, used, final = batched(models, states, args.steps, threads, per_substep)
            how = "one step() call per substep" if per_substep else f"one step(nstep={args.steps}) call"
            rows.append((f"mujoco.batch, {threads} thread{'s' if threads > 1 else ''}, {how}", threads, wall, used,
                         np.array_equal(final, reference)))
    base = rows[0][2]
    print(f"\n{args.sims} simulations x {args.steps} steps of the default trial's model (nv = {models[0].nv}), "
          f"from t = {args.at} s\n")
    print("| how | threads or processes | wall (s) | wall µs per step | CPU µs per step | speed-up (wall) "
          "| bit-identical to the loop |")
    print("|---|---|---|---|---|---|---|")
    for name, n, wall, used, same in rows:
        print(f"| {name} | {n} | {wall:.2f} | {wall / total * 1e6:.0f} | {used / total * 1e6:.0f} | "
              f"{base / wall:.2f} | {'yes' if same else 'NO'} |")


def _specs(count: int, short: bool) -> list[TrialSpec]:
    config = resolve_config(TASK, "balanced", SHORT_SEQUENCE if short else ())
    return [TrialSpec(TASK, "tree", config, 100 + k, "balanced") for k in range(count)]


class _ThreadExecutor:
    """Python threads (for this comparison only): trials share the GIL."""

    def __init__(self, workers: int):
        self.workers = workers

    def map_unordered(self, fn, items):
        with concurrent.futures.ThreadPoolExecutor(self.workers) as pool:
            futures = {pool.submit(fn, item): item for item in items}
            for future in concurrent.futures.as_completed(futures):
                yield futures[future], future.result()


def _timed(executor: Any, specs: list[TrialSpec]) -> tuple[float, list[dict[str, Any]]]:
    with tempfile.TemporaryDirectory() as folder:
        start = time.perf_counter()
        rows = run_trials(specs, TrialLog(Path(folder) / "trials.jsonl"), executor, progress=False)
        return time.perf_counter() - start, rows


def trials_table(args: argparse.Namespace) -> None:
    specs = _specs(args.trials, args.short)
    results = [("serial, this process", *_timed(SerialExecutor(), specs))]
    results.append(("2 local processes (`--workers 2`)", *_timed(ProcessExecutor(2), specs)))
    results.append(("2 Python threads", *_timed(_ThreadExecutor(2), specs)))
    if not args.no_ray:
        import ray

        start = time.perf_counter()
        ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False)
        startup = time.perf_counter() - start
        results.append((f"Ray, local, 2 CPUs (start-up {startup:.1f} s, not included)",
                        *_timed(RayExecutor(), specs)))
        ray.shutdown()
    sim = statistics.mean(r["sim_time_s"] for r in results[0][2])
    kind = "short default" if args.short else "default"
    print(f"\n{args.trials} {kind} trials of the tree ({sim:.1f} s simulated each, balanced)\n")
    print("| executor | wall (s) | wall per trial (s) | trials per hour | same rows as serial |")
    print("|---|---|---|---|---|")
    reference = {r["trial_id"]: (r["outcome"], r["held.acn_total"]) for r in results[0][2]}
    for name, wall, rows in results:
        same = {r["trial_id"]: (r["outcome"], r["held.acn_total"]) for r in rows} == reference
        print(f"| {name} | {wall:.1f} | {wall / len(rows):.2f} | {3600 * len(rows) / wall:.0f} | "
              f"{'yes' if same else 'NO'} |")


def gil_share(args: argparse.Namespace) -> None:
    """CPU time of one default trial inside mj_step (the GIL released) and outside it (Python, GIL held)."""
    import entangle_bench.suite.gripper_task as gripper_task
    from entangle_bench.runner import simulate

    inside = [0.0]
    step = mujoco.mj_step

    def timed_step(model: mujoco.MjModel, data: mujoco.MjData) -> None:
        begin = time.thread_time()
        step(model, data)
        inside[0] += time.thread_time() - begin

    gripper_task.mujoco.mj_step = timed_step
    try:
        begin = time.thread_time()
        simulate(TASK, resolve_config(TASK, "balanced"), 0)
        total = time.thread_time() - begin
    finally:
        gripper_task.mujoco.mj_step = step
    print(f"\none default trial: {total:.2f} CPU s, {inside[0] / total:.0%} in mj_step, {1 - inside[0] / total:.0%} "
          f"in Python between steps (runner, task hooks, watchdog, dm_control) with the GIL held; two threads "
          f"can then run at most {1 / (1 - inside[0] / total / 2):.2f}x as fast as one")


def overhead_table(args: argparse.Namespace) -> None:
    """Per-trial cost of each executor, one worker each, on trials that simulate almost nothing (0.05 s)."""
    from entangle_bench.suite.probe import ProbeConfig

    config = ProbeConfig(duration_s=0.05, ramp_time_s=0.02)
    specs = [TrialSpec("probe/curl_in_air", "tiny", config, k, "balanced") for k in range(args.tiny)]
    results = [("serial, this process", 0.0, _timed(SerialExecutor(), specs)[0])]
    start = time.perf_counter()
    list(ProcessExecutor(1).map_unordered(abs, [1]))  # what starting a worker process costs
    spawn = time.perf_counter() - start
    results.append(("1 local worker process", spawn, _timed(ProcessExecutor(1), specs)[0] - spawn))
    if not args.no_ray:
        import ray

        start = time.perf_counter()
        ray.init(address="local", num_cpus=1, include_dashboard=False, log_to_driver=False)
        _timed(RayExecutor(), specs[:1])  # the first task starts Ray's worker process
        startup = time.perf_counter() - start
        results.append(("Ray, local, 1 CPU", startup, _timed(RayExecutor(), specs)[0]))
        ray.shutdown()
    base = results[0][2] / len(specs)
    print(f"\n{len(specs)} tiny trials (probe/curl_in_air, 0.05 s simulated), one worker: cost per trial\n")
    print("| executor | start-up (s, not included) | wall (s) | wall per trial (ms) | added per trial (ms) |")
    print("|---|---|---|---|---|")
    for name, startup, wall in results:
        print(f"| {name} | {startup:.1f} | {wall:.1f} | {wall / len(specs) * 1e3:.0f} | "
              f"{(wall / len(specs) - base) * 1e3:+.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sims", type=int, default=8, help="simulations in part 1 (even)")
    parser.add_argument("--steps", type=int, default=500, help="physics steps per simulation in part 1")
    parser.add_argument("--at", type=float, default=2.0, help="trial time (s) of part 1's starting state")
    parser.add_argument("--trials", type=int, default=6, help="trials per executor in part 2")
    parser.add_argument("--short", action="store_true", help="part 2 with SHORT_SEQUENCE trials")
    parser.add_argument("--no-ray", action="store_true")
    parser.add_argument("--tiny", type=int, default=40, help="tiny trials per executor in part 3")
    parser.add_argument("--part", choices=("physics", "trials", "overhead", "all"), default="all")
    args = parser.parse_args()
    load = os.getloadavg()
    print(f"machine: {platform.machine()}, {os.cpu_count()} CPUs, load average {load[0]:.1f} at start; "
          f"python {platform.python_version()}, mujoco {mujoco.__version__}")
    if args.part in ("physics", "all"):
        physics_table(args)
        gil_share(args)
    if args.part in ("trials", "all"):
        trials_table(args)
    if args.part in ("overhead", "all"):
        overhead_table(args)
    print(f"\nload average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
