"""Benchmark: what watching a trial costs - MCAP recording size and time, video time per frame.

Runs the default eight_branch_tree trial (full phases) three times with the same seed: bare, with a
`TrialRecorder` (a sample every --record-period s of simulated time), and with a `TrialVideo` (a frame every
--frame-period s), and prints a markdown table. The video backend is matplotlib unless MUJOCO_GL=egl or osmesa
is set. Usage: python scripts/bench_watch.py [--preset balanced] [--size 640x480]
"""

from __future__ import annotations

import argparse
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

from entangle_bench.recording import TrialRecorder
from entangle_bench.runner import simulate
from entangle_bench.suite import resolve_config
from entangle_bench.video import TrialVideo


def run(config: Any, observers: list[Any], seed: int = 0) -> Any:
    """One top-drape trial of `config` run by the runner (`runner.simulate`) with `observers`; return the
    finished environment."""
    return simulate(f"top_drape/{config.object_name}", config, seed, observers=observers).env


def timed(config: Any, observers: list[Any]) -> tuple[float, float]:
    """(simulated s, wall s) of one observed trial."""
    start = time.perf_counter()
    env = run(config, observers)
    return env.physics.time(), time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--preset", default="balanced")
    parser.add_argument("--record-period", type=float, default=0.05)
    parser.add_argument("--frame-period", type=float, default=0.1)
    parser.add_argument("--size", default="640x480")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    config = resolve_config("eight_branch_tree", args.preset)
    print(f"machine: {platform.machine()} python {platform.python_version()}; default tree trial, {args.preset}")
    with tempfile.TemporaryDirectory() as folder:
        sim_s, bare = timed(config, [])
        recorder = TrialRecorder(Path(folder) / "t.mcap", period_s=args.record_period)
        _, recorded = timed(config, [recorder])
        video = TrialVideo(Path(folder) / "t.mp4", period_s=args.frame_period, size=(width, height))
        _, filmed = timed(config, [video])
        size = recorder.path.stat().st_size
        print("| run | wall (s) | extra per simulated s | output |")
        print("|---|---|---|---|")
        print(f"| bare, {sim_s:.1f} s simulated | {bare:.1f} | - | - |")
        print(f"| recording every {args.record_period * 1e3:.0f} ms | {recorded:.1f} | "
              f"{(recorded - bare) / sim_s:.3f} s | {size / 1e3:.0f} kB = {size / sim_s / 1e3:.0f} kB per simulated s "
              f"({recorder.samples} samples) |")
        print(f"| video every {args.frame_period * 1e3:.0f} ms, {width}x{height}, {video.backend} | {filmed:.1f} | "
              f"{(filmed - bare) / sim_s:.2f} s | {video.frames} frames, {video.seconds_per_frame * 1e3:.0f} ms "
              f"per frame, {video.path.stat().st_size / 1e3:.0f} kB |")


if __name__ == "__main__":
    main()
