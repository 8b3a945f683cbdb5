"""Top-drape task: registry, determinism, outcome logic, watchdog, a short real trial."""

import dataclasses

import mujoco
import numpy as np
import pytest

from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.runner import TrialSpec, run_trial
from entangle_bench.suite import SHORT_SEQUENCE, TASKS, load, resolve_config
from entangle_bench.suite.top_drape import Schedule, make_environment, scripted_action

SHORT = SHORT_SEQUENCE


def short_spec(task="eight_branch_tree", seed=0, extra=(), preset="fast"):
    config = resolve_config(task, preset, SHORT + list(extra))
    return TrialSpec(f"top_drape/{task}", task, config, seed, preset)


def test_every_object_has_a_task_and_unknown_names_list_known_ones():
    assert "top_drape/eight_branch_tree" in TASKS.names()
    with pytest.raises(UnknownNameError, match="eight_branch_tree"):
        TASKS.get("no_such_object")
    with pytest.raises(UnknownNameError):
        load("top_drape", "no_such_object")


def test_bad_overrides_name_the_field():
    with pytest.raises(ParameterError, match="phases.hold_time_s"):
        resolve_config("eight_branch_tree", None, ["phases.hold_time_s=-1"])
    with pytest.raises(ParameterError, match="unknown setting"):
        resolve_config("eight_branch_tree", None, ["phases.no_such_field=1"])


def test_schedule_phases_are_ordered():
    config = resolve_config("eight_branch_tree")
    s = Schedule.from_config(config, 0.144)
    assert 0 < s.t_actuate < s.t_settle < s.t_lift < s.t_hold < s.t_release < s.t_end
    assert s.phase(0.0) == "approach" and s.phase(s.t_hold + 1e-3) == "hold"
    assert s.hub_start_z - s.hub_drape_z == pytest.approx(
        config.phases.drape_depth_m + config.phases.start_clearance_m
    )


@pytest.mark.parametrize("task", sorted(TASKS.names()))
def test_registry_wide_invariants(task):
    """Every registered task: finite observations, valid action spec, seeded reset."""
    env = load(*task.split("/"), seed=1, preset="fast", overrides=SHORT)
    step = env.reset()
    for value in step.observation.values():
        assert np.all(np.isfinite(value))
    spec = env.action_spec()
    assert spec.shape == (4,)
    for _ in range(5):
        step = env.step(np.array([0.0, 0.0, -0.1, 0.0]))
    assert all(np.all(np.isfinite(v)) for v in step.observation.values())
    hub_a = env.physics.hub_position()
    other = load(*task.split("/"), seed=2, preset="fast", overrides=SHORT)
    other.reset()
    if env.task.config.offset_m == 0.0:
        assert not np.allclose(env.task.angles, other.task.angles)  # the seed draws bending planes
    assert np.isfinite(hub_a).all()


def test_same_seed_same_trajectory():
    finals = []
    for _ in range(2):
        env = make_environment(short_spec(seed=5).config, 5)
        step = env.reset()
        while not step.last():
            step = env.step(scripted_action(env.task.config, env.task.schedule, env.physics.time()))
        finals.append((env.physics.data.qpos.copy(), env.task.outcome.classify()))
    assert np.array_equal(finals[0][0], finals[1][0])
    assert finals[0][1] == finals[1][1]


def test_zero_pressure_never_lifts():
    row = run_trial(short_spec(extra=["gripper.pressure_pa=0"]))
    assert row["outcome"] == "failure" and row["failure_mode"] == "never_lifted"
    assert row["lift_height_m"] < 0.005


def test_object_welded_to_hub_is_a_success(monkeypatch):
    """Outcome logic: an object carried rigidly by the hub during lift and hold is a success."""
    from entangle_bench.suite import top_drape

    original = top_drape.Physics.step

    def carried_step(self, nstep=1):
        before = self.data.mocap_pos[0].copy()
        original(self, nstep)
        rise = self.data.mocap_pos[0, 2] - before[2]
        if self.time() > self.scene_lift_start:
            model, body = self.model.ptr, self.scene.object_body
            joint = model.body_jntadr[body]
            model.body_gravcomp[body] = 1.0  # carried: weightless, moving with the hub
            self.data.qpos[model.jnt_qposadr[joint] + 2] += rise
            self.data.qvel[model.jnt_dofadr[joint] : model.jnt_dofadr[joint] + 6] = 0.0
            self.data.qvel[model.jnt_dofadr[joint] + 2] = self.hub_velocity[2]
            mujoco.mj_forward(model, self.data.ptr)

    spec = short_spec()
    monkeypatch.setattr(top_drape.Physics, "step", carried_step)
    monkeypatch.setattr(
        top_drape.Physics, "scene_lift_start", Schedule.from_config(spec.config, 0.144).t_lift, raising=False
    )
    row = run_trial(spec)
    assert row["outcome"] == "success", {k: row[k] for k in ("failure_mode", "lift_height_m", "hold_time_reached_s")}
    assert row["lift_height_m"] >= 0.95 * spec.config.phases.lift_height_m


def test_injected_nan_is_unstable_not_a_failed_grasp():
    row = run_trial(short_spec(), inject_nan_at_s=0.3)
    assert row["outcome"] == "unstable"
    assert row["failure_mode"] == ""
    assert row["success"] is False
    assert row["unstable_time_s"] == pytest.approx(0.3, abs=0.05)
    assert row["unstable_reason"]


def test_short_real_trial_of_default_tree_task():
    """The default task and preset, shortened phases: completes with a classified outcome and metrics."""
    config = resolve_config("eight_branch_tree", None, SHORT)
    row = run_trial(TrialSpec("top_drape/eight_branch_tree", "tree", config, 0, "balanced"))
    assert row["outcome"] in ("success", "failure")
    assert row["sim_time_s"] == pytest.approx(
        Schedule.from_config(config, 0.144).t_end, abs=0.02
    )
    assert row["actuated.contacts.filament-object"] >= 0
    assert np.isfinite(row["held.acn_total"])
    assert dataclasses.asdict(config)  # resolved config is a plain dataclass tree
