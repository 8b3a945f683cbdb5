"""Branching a trial: run it to a point, save everything a continuation needs, continue once per variant.

Studies that compare solver settings on one grasp (`hold_creep`, `scripts/bench_solvers.py`) run a trial
with its scripted policy until a condition holds (`run_until`), save MuJoCo's integration state with the
model fields a task changes at run time, the task's attributes and the environment's step count
(`SavedTrial`), and continue from that state once per variant of `mjOption` fields (`option_variants`), so
every variant starts from the identical state and they compare solvers, not seeds.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from entangle_bench.suite import TASKS

#: Model fields a task changes at run time: the springs' reference pose (the pressure) and contact filters.
_MODEL_FIELDS = ("qpos_spring", "geom_contype", "geom_conaffinity")


def run_until(task: str, config: Any, seed: int, until: Callable[[Any], bool]) -> tuple[Any, bool]:
    """The trial's environment stepped with its scripted policy until `until(env)` holds or the trial ends;
    the environment and whether it ended first."""
    env = TASKS.get(task).make_environment(config, seed)
    time_step, physics = env.reset(), env.physics
    while not until(env):
        if time_step.last():
            return env, True
        time_step = env.step(env.task.scripted_action(physics))
    return env, False


@dataclass(frozen=True)
class SavedTrial:
    """Everything a continuation needs: MuJoCo's integration state, the model fields the task changes at run
    time, the task's attributes and the environment's step count."""

    state: np.ndarray
    model: dict[str, np.ndarray]
    task: dict[str, Any]
    step_count: int

    @classmethod
    def take(cls, env: Any) -> SavedTrial:
        """Save the environment's current state."""
        model, data = env.physics.model.ptr, env.physics.data.ptr
        state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_INTEGRATION))
        mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_INTEGRATION)
        fields = {name: getattr(model, name).copy() for name in _MODEL_FIELDS}
        return cls(state, fields, copy.deepcopy(vars(env.task)), env._step_count)

    def restore(self, env: Any) -> None:
        """Put the environment back into the saved state (mjOption is left as it is) with MuJoCo's warning
        counters cleared: `mj_setState` keeps them, and a previous continuation's warnings would trip the
        watchdog at the next one's first check."""
        model, data = env.physics.model.ptr, env.physics.data.ptr
        for name, value in self.model.items():
            getattr(model, name)[:] = value
        mujoco.mj_setState(model, data, self.state, mujoco.mjtState.mjSTATE_INTEGRATION)
        for warning in data.warning:
            warning.number, warning.lastinfo = 0, 0
        mujoco.mj_forward(model, data)
        vars(env.task).update(copy.deepcopy(self.task))
        env._step_count, env._reset_next_step = self.step_count, False


def option_variants(model: Any, variants: Mapping[str, Mapping[str, Any]]) -> Iterator[str]:
    """Set each variant's `mjOption` fields in turn, every other field a variant changes back at its configured
    value, and yield the variant's name. A value may be a function of the configured value (e.g. one more bit
    in `disableflags`)."""
    configured = {name: getattr(model.opt, name) for changes in variants.values() for name in changes}
    for name, changes in variants.items():
        for field, value in {**configured, **changes}.items():
            setattr(model.opt, field, value(configured[field]) if callable(value) else value)
        yield name
