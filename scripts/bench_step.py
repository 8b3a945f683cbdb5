"""Benchmark: wall time per step and real-time factor of the default gripper hanging and actuating in air.

Prints a markdown table over segment counts x timesteps (and the presets). Compare ratios within one run:
the machine is shared and noisy. Usage: python scripts/bench_step.py [--sim-time 2.0]
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import time

import mujoco
import numpy as np

from entangle_bench.gripper import bending_angles
from entangle_bench.presets import PRESETS, Numerics
from entangle_bench.scene import SceneConfig, build_scene


def measure(config: SceneConfig, sim_time_s: float) -> tuple[float, bool]:
    """(wall seconds per step, stayed finite and warning-free) for a ramp to full pressure in air."""
    scene = build_scene(config)
    model, data = scene.model, mujoco.MjData(scene.model)
    angles = bending_angles(config.gripper, np.random.default_rng(0))
    steps = int(round(sim_time_s / model.opt.timestep))
    per_update = max(1, int(round(0.01 / model.opt.timestep)))
    start = time.perf_counter()
    for _ in range(0, steps, per_update):
        pressure = config.gripper.pressure_pa * min(1.0, data.time / (0.5 * sim_time_s))
        scene.gripper.set_pressure(model, pressure, angles)
        mujoco.mj_step(model, data, per_update)
    wall = time.perf_counter() - start
    ok = bool(np.all(np.isfinite(data.qpos))) and all(w.number == 0 for w in data.warning)
    return wall / steps, ok


def row(label: str, config: SceneConfig, sim_time_s: float) -> str:
    per_step, ok = measure(config, sim_time_s)
    dt = config.numerics.timestep_s
    n = config.gripper.filament.n_segments
    rtf = dt / per_step
    cells = [label, n, f"{dt * 1e3:g}", config.numerics.integrator, f"{per_step * 1e6:.0f}", f"{rtf:.2f}"]
    return "| " + " | ".join(map(str, cells + ["yes" if ok else "NO"])) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sim-time", type=float, default=2.0, help="simulated seconds per case")
    args = parser.parse_args()
    print(f"machine: {platform.machine()} {platform.processor() or ''} python {platform.python_version()} "
          f"mujoco {mujoco.__version__}; 12 filaments in free air, pressure ramp then hold")
    print("| case | segments | dt (ms) | integrator | wall per step (us) | real-time factor | stable |")
    print("|---|---|---|---|---|---|---|")
    base = SceneConfig()
    for name, preset in PRESETS.items():
        filament = dataclasses.replace(base.gripper.filament, n_segments=preset.n_segments)
        config = dataclasses.replace(
            base, gripper=dataclasses.replace(base.gripper, filament=filament), numerics=preset.numerics
        )
        print(row(f"preset {name}", config, args.sim_time), flush=True)
    for n in (12, 16, 24, 32):
        for dt in (1e-3, 2e-3, 4e-3):
            filament = dataclasses.replace(base.gripper.filament, n_segments=n)
            config = dataclasses.replace(
                base,
                gripper=dataclasses.replace(base.gripper, filament=filament),
                numerics=Numerics(timestep_s=dt),
            )
            print(row("sweep", config, args.sim_time), flush=True)


if __name__ == "__main__":
    main()
