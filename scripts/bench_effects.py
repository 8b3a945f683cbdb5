"""Benchmark: cost of each optional effect in the default tree trial, as a markdown table.

Runs the default eight_branch_tree trial (seed 0, balanced preset unless --preset) with every effect
on, then with each optional effect of `entangle_bench.effects.OPTIONAL_EFFECTS` switched off in
turn, and prints wall time per simulated second, the compiled model's collision-pair count and the
outcome. `--short` shortens the phases (the test suite's short sequence) for a quick run. Usage:
python scripts/bench_effects.py [--preset balanced] [--short] [--repeats 1] Not a test: timings
depend on the machine and its load.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import time
from pathlib import Path

import mujoco

from entangle_bench import effects as fx
from entangle_bench.runner import TrialSpec, run_trial
from entangle_bench.scene import build_scene
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config


def machine() -> str:
    """CPU model (from /proc/cpuinfo where there is one) and core count."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return f"{model}, {os.cpu_count()} cores"


def main() -> None:
    """Run the variants and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="balanced")
    parser.add_argument("--short", action="store_true", help="short phases (quick run)")
    parser.add_argument(
        "--repeats", type=int, default=1, help="runs per variant; the fastest counts"
    )
    args = parser.parse_args()
    base = resolve_config("eight_branch_tree", args.preset, SHORT_SEQUENCE if args.short else [])
    variants = {"all on (default)": base.effects}
    variants.update(
        {f"{name} off": fx.switched_off(base.effects, name) for name in fx.OPTIONAL_EFFECTS}
    )
    print(
        f"machine: {machine()}, python {platform.python_version()}, mujoco {mujoco.__version__}; "
        f"default eight_branch_tree trial, seed 0, preset {args.preset}"
        f"{', short phases' if args.short else ''}"
    )
    print("| variant | collision pairs | wall per simulated second (s) | relative | outcome |")
    print("|---|---|---|---|---|")
    reference = None
    for label, effects in variants.items():
        config = dataclasses.replace(base, effects=effects)
        pairs = len(fx.collision_pairs(build_scene(config.scene_config()).model))
        best, row = float("inf"), {}
        for _ in range(args.repeats):
            start = time.perf_counter()
            row = run_trial(TrialSpec("top_drape/eight_branch_tree", label, config, 0, args.preset))
            best = min(best, (time.perf_counter() - start) / row["sim_time_s"])
        reference = reference or best
        outcome = row["outcome"] + (
            f" ({row['failure_mode'] or row['unstable_reason']})"
            if row["outcome"] != "success"
            else ""
        )
        print(
            f"| {label} | {pairs} | {best:.3f} | {best / reference:.2f} | {outcome} |", flush=True
        )


if __name__ == "__main__":
    main()
