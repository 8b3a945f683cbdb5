"""Invariants of every registered task (dm_control's suite_test.py, over our registry).

A task is tested the moment it is registered: its config type, phases and snapshots; observations matching
their spec; scripted actions inside the action spec; reward in [0, 1] and equal to the decided outcome; the
outcome decided exactly once; the same seed giving the same trajectory; different seeds different initial
states. Each task runs a short sequence on the fast preset, so the whole registry takes well under a minute.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

from entangle_bench.suite import SHORT_PULL_SEQUENCE, SHORT_SEQUENCE, TASKS, BenchTask, resolve_config

#: Short-sequence overrides per task family.
SHORT = {
    "top_drape": SHORT_SEQUENCE,
    "pullout": SHORT_PULL_SEQUENCE,
    "probe": ["duration_s=0.3", "ramp_time_s=0.1"],
}

#: Control steps compared between two runs of one seed.
COMPARED_STEPS = 40


def short_environment(task: str, seed: int):
    """The task's environment on a short sequence and the fast preset."""
    entry = TASKS.get(task)
    return entry.make_environment(resolve_config(task, "fast", SHORT[entry.domain]), seed)


@functools.cache
def scripted_rollout(task: str, seed: int, max_steps: int | None = None) -> dict:
    """Run the scripted policy; record every step's observation, action, reward, outcome and qpos."""
    env = short_environment(task, seed)
    step = env.reset()
    record = {"env": env, "first": step, "steps": []}
    while not step.last() and (max_steps is None or len(record["steps"]) < max_steps):
        action = env.task.scripted_action(env.physics)
        step = env.step(action)
        record["steps"].append(
            {
                "action": action,
                "step": step,
                "outcome": env.task.outcome,
                "qpos": env.physics.data.qpos.copy(),
                "phase": env.task.phase(env.physics),
            }
        )
    return record


def test_every_family_has_a_short_sequence():
    assert {TASKS.get(name).domain for name in TASKS.names()} <= set(SHORT)


@pytest.mark.parametrize("task", TASKS.names())
def test_registration(task):
    """The entry's config type, the task class, its phases and snapshot points agree."""
    entry = TASKS.get(task)
    assert entry.name == task
    assert isinstance(entry.default_config(), entry.config_type)
    assert TASKS.entry(task).description
    env = short_environment(task, 0)
    assert isinstance(env.task, BenchTask)
    assert env.task.PHASES and set(env.task.SNAPSHOTS.values()) <= set(env.task.PHASES)
    env.reset()
    assert env.task.phase(env.physics) == env.task.PHASES[0]
    assert env.task.outcome is None
    assert env.task.actuation_energy_j() > 0.0  # every registered task actuates its filaments


@pytest.mark.parametrize("task", TASKS.names())
def test_scripted_rollout_respects_specs_and_decides_once(task):
    record = scripted_rollout(task, 5)
    env = record["env"]
    observation_spec, action_spec = env.observation_spec(), env.action_spec()
    steps = record["steps"]
    assert steps, "no step ran"
    for step_record in [{"step": record["first"]}, *steps]:
        observation = step_record["step"].observation
        assert set(observation) == set(observation_spec)
        for name, spec in observation_spec.items():
            value = np.asarray(observation[name])
            assert value.shape == spec.shape and value.dtype == spec.dtype, name
            assert np.all(np.isfinite(value)), name
    for step_record in steps:
        action = step_record["action"]
        assert action.shape == action_spec.shape
        assert np.all(action >= action_spec.minimum) and np.all(action <= action_spec.maximum)
        reward = step_record["step"].reward
        assert 0.0 <= reward <= 1.0
        outcome = step_record["outcome"]
        assert reward == float(outcome is not None and outcome.success)
        assert step_record["phase"] in env.task.PHASES
    outcomes = [s["outcome"] for s in steps]
    decided = next(k for k, o in enumerate(outcomes) if o is not None)
    assert all(o is None for o in outcomes[:decided])
    assert all(o is outcomes[decided] for o in outcomes[decided:]), "the outcome was decided more than once"
    outcome = outcomes[-1]
    assert outcome.status in ("success", "failure") and (outcome.failure_mode == "") == outcome.success
    assert outcome.decided_at_s <= env.physics.time() + 1e-9
    phases = [s["phase"] for s in steps]
    assert [p for p in env.task.PHASES if p in phases] == list(dict.fromkeys(phases)), "phases out of order"


@pytest.mark.parametrize("task", TASKS.names())
def test_same_seed_same_trajectory(task):
    reference = scripted_rollout(task, 5)["steps"][:COMPARED_STEPS]
    again = scripted_rollout.__wrapped__(task, 5, COMPARED_STEPS)["steps"]
    assert len(again) == len(reference)
    for a, b in zip(reference, again):
        assert np.array_equal(a["qpos"], b["qpos"])
        assert a["step"].reward == b["step"].reward


@pytest.mark.parametrize("task", TASKS.names())
def test_reset_randomizes_the_initial_state(task):
    states = []
    for seed in (1, 2):
        env = short_environment(task, seed)
        env.reset()
        states.append(env.physics.data.qpos.copy())
    assert not np.array_equal(*states)
