"""Top-drape task family: registration, schedule, the one outcome decision, watchdog, a short real trial."""

import mujoco
import numpy as np
import pytest

from entangle_bench import objects
from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.geoms import KINDS
from entangle_bench.metrics.acn import acn_total
from entangle_bench.runner import TrialSpec, run_trial, simulate
from entangle_bench.suite import SHORT_SEQUENCE, TASKS, load, resolve_config
from entangle_bench.suite.gripper_task import ScenePhysics
from entangle_bench.suite.top_drape import Schedule, TopDrapeConfig


def test_every_object_has_a_task_and_unknown_names_list_known_ones():
    top_drape = [n.split("/", 1)[1] for n in TASKS.names() if n.startswith("top_drape/")]
    assert top_drape == objects.names()
    assert TASKS.get("eight_branch_tree") is TASKS.get("top_drape/eight_branch_tree")
    assert TASKS.get("sphere").config_type is TopDrapeConfig
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


def test_zero_pressure_never_lifts(short_spec):
    row = run_trial(short_spec(extra=["gripper.pressure_pa=0"]))
    assert row["outcome"] == "failure" and row["failure_mode"] == "never_lifted"
    assert row["lift_clearance_m"] < 0.005
    assert row["hold_min_clearance_m"] == pytest.approx(0.0, abs=1e-3)  # resting on the ground (soft contact)


def test_object_welded_to_hub_is_a_success(monkeypatch, short_spec):
    """Outcome logic: an object carried rigidly by the hub during lift and hold is a success, decided once."""
    original = ScenePhysics.step
    spec = short_spec()
    lift_start = Schedule.from_config(spec.config, 0.144).t_lift

    def carried_step(self, nstep=1):
        before = self.data.mocap_pos[0].copy()
        original(self, nstep)
        rise = self.data.mocap_pos[0, 2] - before[2]
        if self.time() > lift_start:
            model, body = self.model.ptr, self.scene.object_body
            joint = model.body_jntadr[body]
            model.body_gravcomp[body] = 1.0  # carried: weightless, moving with the hub
            self.data.qpos[model.jnt_qposadr[joint] + 2] += rise
            self.data.qvel[model.jnt_dofadr[joint] : model.jnt_dofadr[joint] + 6] = 0.0
            self.data.qvel[model.jnt_dofadr[joint] + 2] = self.hub_velocity[2]
            mujoco.mj_forward(model, self.data.ptr)

    monkeypatch.setattr(ScenePhysics, "step", carried_step)
    result = simulate(spec.task, spec.config, spec.seed)
    row, task = result.row, result.env.task
    assert row["outcome"] == "success", {k: row[k] for k in ("failure_mode", "lift_clearance_m", "hold_time_reached_s")}
    assert row["lift_clearance_m"] >= 0.95 * spec.config.phases.lift_height_m
    assert spec.config.success_margin_m <= row["hold_min_clearance_m"] <= row["lift_clearance_m"]
    assert task.outcome.success and task.outcome.evidence["lifted"] == 1.0
    assert task.outcome.decided_at_s == pytest.approx(task.schedule.t_release, abs=spec.config.control_timestep_s)
    assert np.isnan(task.outcome.evidence["hold_failed_at_s"])
    assert row["hold_time_reached_s"] == pytest.approx(spec.config.phases.hold_time_s, abs=0.011)
    assert task.get_reward(result.env.physics) == 1.0


def test_injected_nan_is_unstable_not_a_failed_grasp(short_spec, nan_at):
    row = run_trial(short_spec(), observers=[nan_at(0.3)])
    assert row["outcome"] == "unstable"
    assert row["failure_mode"] == ""
    assert row["success"] is False
    assert row["unstable_time_s"] == pytest.approx(0.3, abs=0.05)
    assert row["unstable_reason"].startswith("PhysicsError:") and "mjWARN_BADQVEL" in row["unstable_reason"]


def test_short_real_trial_of_default_tree_task(tmp_path):
    """The default task and preset, shortened phases: the row, the saved states and the config agree."""
    config = resolve_config("eight_branch_tree", None, SHORT_SEQUENCE)
    spec = TrialSpec("top_drape/eight_branch_tree", "tree", config, 0, "balanced")
    row = run_trial(spec, folder=tmp_path)
    assert row["outcome"] in ("success", "failure")
    assert row["success"] == (row["outcome"] == "success") and (row["failure_mode"] == "") == row["success"]
    assert row["sim_time_s"] == pytest.approx(Schedule.from_config(config, 0.144).t_end, abs=0.02)
    for name in ("actuated", "held"):
        saved = np.load(tmp_path / "states" / f"{spec.trial_id}_{name}.npz")
        assert saved["curves"].shape == (12, 17, 3)  # 12 filaments, balanced: 16 segments
        assert row[f"{name}.acn_total"] == pytest.approx(acn_total(saved["curves"]), rel=1e-12)
        for kind in KINDS:
            assert row[f"{name}.contacts.{kind}"] == int(np.count_nonzero(saved["contact_kinds"] == kind))
    assert row["actuated.contacts.object-ground"] > 0  # the tree stands on the ground when actuated
    assert row["config.gripper.filament.n_segments"] == 16
    assert row["config.phases.hold_time_s"] == 0.3 and row["config.object_name"] == "eight_branch_tree"


class _OptionByPhase:
    """Observer: per control step, the phase it ran in, the mjOption `option` it ran with, and qpos after it."""

    def __init__(self, option):
        self.option, self.steps = option, []

    def start(self, env):
        self.phase = env.task.phase(env.physics)

    def step(self, env):
        physics = env.physics
        self.steps.append((self.phase, getattr(physics.model.opt, self.option), physics.data.qpos.copy()))
        self.phase = env.task.phase(physics)

    def finish(self, row, complete):
        pass


@pytest.mark.parametrize("option, base, plain, switched, on, off", [
    # noslip in lift and hold: the noslip solver acts on the contacts carrying the object.
    ("noslip_iterations", [], [], ["numerics.noslip_iterations=10", "numerics.noslip_phases=lift,hold"], 10, 0),
    # impratio 10 in lift and hold, 1 elsewhere: compared with impratio 1 throughout.
    ("impratio", ["effects.cone=elliptic"], ["numerics.impratio=1"],
     ["numerics.impratio=10", "numerics.impratio_phases=lift,hold"], 10.0, 1.0),
])
def test_per_phase_option_applies_only_in_its_phases_and_leaves_the_rest_unchanged(option, base, plain, switched,
                                                                                   on, off):
    """With the option's phases = lift, hold the trajectory is bit-identical to the plain trial up to the lift (the
    option is at its off value), and differs from the lift on."""
    base = [*SHORT_SEQUENCE, "numerics.timestep_s=1e-3", *base]
    runs = {}
    for name, extra in (("plain", plain), ("lift_hold", switched)):
        probe = _OptionByPhase(option)
        simulate("eight_branch_tree", resolve_config("eight_branch_tree", "fast", [*base, *extra]), 0,
                 observers=[probe])
        runs[name] = probe.steps
    plain, switched = runs["plain"], runs["lift_hold"]
    assert [p for p, _, _ in plain] == [p for p, _, _ in switched]
    assert {p for p, v, _ in switched if v == on} == {"lift", "hold"}
    assert {p for p, v, _ in switched if v == off} == {"approach", "actuate", "settle", "release"}
    first_lift = next(i for i, (p, _, _) in enumerate(switched) if p == "lift")
    for (_, _, q_plain), (_, _, q_switched) in zip(plain[:first_lift], switched[:first_lift]):
        np.testing.assert_array_equal(q_plain, q_switched)
    assert np.abs(plain[-1][2] - switched[-1][2]).max() > 1e-9


def test_per_phase_options_must_name_task_phases_and_noslip_needs_iterations():
    with pytest.raises(ParameterError, match="noslip_iterations > 0"):
        resolve_config("eight_branch_tree", None, ["numerics.noslip_phases=lift"])
    config = resolve_config("eight_branch_tree", None, ["numerics.noslip_iterations=5", "numerics.noslip_phases=lfit"])
    with pytest.raises(ParameterError, match=r"noslip_phases = 'lfit'.*'lift', 'hold'"):
        TASKS.get("eight_branch_tree").make_environment(config, 0)
    config = resolve_config("eight_branch_tree", None, ["numerics.impratio_phases=hodl"])
    with pytest.raises(ParameterError, match=r"impratio_phases = 'hodl'.*'lift', 'hold'"):
        TASKS.get("eight_branch_tree").make_environment(config, 0)
