"""Shared test settings, fixtures and builders: headless plotting, quiet MuJoCo, short trials, test observers.

Builders are fixtures that return a function, so test modules never import from one another.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
import pytest

from entangle_bench import effects as fx
from entangle_bench.filament import FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import Numerics
from entangle_bench.runner import TrialSpec
from entangle_bench.scene import Scene, SceneConfig, build_scene
from entangle_bench.suite import SHORT_SEQUENCE, TASKS, resolve_config

os.environ.setdefault("MPLBACKEND", "Agg")

#: Numerics for reaching static equilibrium quickly: implicit damping allows a long relaxation time.
STATICS = Numerics(timestep_s=1e-3, integrator="implicitfast", twist_armature_scale=100.0)

#: Segments of the single test filament unless a test sets its own (the value its tolerances were set with).
SINGLE_FILAMENT_SEGMENTS = 24


@pytest.fixture
def quiet_mujoco():
    """Silence MuJoCo's warning printer (for tests that provoke warnings on purpose), then restore it."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)
    yield
    mujoco.set_mju_user_warning(previous)


@pytest.fixture
def short_spec() -> Callable[..., TrialSpec]:
    """Builder of a short top-drape trial spec: (task, seed, extra overrides, preset) -> TrialSpec."""

    def build(task: str = "eight_branch_tree", seed: int = 0, extra=(), preset: str = "fast") -> TrialSpec:
        name = TASKS.entry(task).value.name
        config = resolve_config(name, preset, [*SHORT_SEQUENCE, *extra])
        return TrialSpec(name, task, config, seed, preset)

    return build


@pytest.fixture
def single_filament_scene() -> Callable[..., Scene]:
    """Builder of one filament clamped at (0, 0, 0.5) hanging along -z, curling toward +x when actuated."""

    def build(effects: fx.Effects = fx.ISOLATED, numerics: Numerics = STATICS, **filament: Any) -> Scene:
        filament.setdefault("n_segments", SINGLE_FILAMENT_SEGMENTS)
        params = dataclasses.replace(FilamentParams(damping_time_s=0.2), **filament)
        gripper = GripperParams(
            filament=params, ring_diameters_m=(0.0,), ring_counts=(1,), bending_plane="fixed"
        )
        return build_scene(SceneConfig(gripper=gripper, effects=effects, numerics=numerics))

    return build


class StartHook:
    """Test observer: applies `prepare(physics)` to the reset state (then mj_forward) before the first step."""

    def __init__(self, prepare: Callable[[Any], None]):
        self.prepare = prepare

    def start(self, env: Any) -> None:
        """Change the initial state."""
        self.prepare(env.physics)
        mujoco.mj_forward(env.physics.model.ptr, env.physics.data.ptr)

    def step(self, env: Any) -> None:
        """Nothing per step."""

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to close."""


class NanInjector:
    """Test observer: corrupts the state (qvel[0] = NaN) once the simulated time reaches `time_s`."""

    def __init__(self, time_s: float):
        self.time_s = time_s

    def start(self, env: Any) -> None:
        """Corrupt at once if the time is zero."""
        self.step(env)

    def step(self, env: Any) -> None:
        """Corrupt the velocities once the time has come."""
        if env.physics.time() >= self.time_s:
            env.physics.data.qvel[0] = np.nan

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to close."""


@pytest.fixture
def start_hook() -> type[StartHook]:
    """The StartHook observer class: `start_hook(prepare)`."""
    return StartHook


@pytest.fixture
def nan_at() -> type[NanInjector]:
    """The NanInjector observer class: `nan_at(time_s)`."""
    return NanInjector
