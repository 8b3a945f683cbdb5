"""Runtime watchdog: each check trips on real trouble, with reason and time, not on a sound run."""

import math

import mujoco
import numpy as np
import pytest

from entangle_bench.watchdog import (
    Watchdog,
    WatchdogLimits,
    WatchdogTripped,
    body_speeds,
    mechanical_energy,
)

pytestmark = pytest.mark.usefixtures("quiet_mujoco")


def pendulum(gravcomp: float = 0.0, box: bool = True) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """A 0.1 kg bob on a 0.5 m hinge, a ground plane and (optionally) a box resting on it."""
    spec = mujoco.MjSpec()
    spec.option.timestep = 1e-3
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=(1, 1, 0.01))
    arm = spec.worldbody.add_body(name="arm", pos=(0, 0, 1.0), gravcomp=gravcomp)
    arm.add_joint(type=mujoco.mjtJoint.mjJNT_HINGE, axis=(0, 1, 0))
    arm.add_geom(
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=(0.01, 0, 0),
        pos=(0, 0, -0.5),
        mass=0.1,
        contype=0,
        conaffinity=0,
    )
    if box:
        body = spec.worldbody.add_body(name="box", pos=(0.5, 0, 0.05))
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=(0.05, 0.05, 0.05), mass=0.2)
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[0] = 1.0
    mujoco.mj_forward(model, data)
    return model, data


def run(model, data, watchdog, seconds):
    while data.time < seconds - 1e-9:
        mujoco.mj_step(model, data, nstep=10)
        watchdog.check(model, data)


def test_sound_run_does_not_trip_and_records_its_worst_values():
    model, data = pendulum(box=False)
    watchdog = Watchdog(model, data, WatchdogLimits(energy_slack_j=1e-3), actuation_energy_j=0.0)
    run(model, data, watchdog, 2.0)
    stats = watchdog.stats
    assert stats.checks == 200
    # Bob speed at the bottom: sqrt(2 g l (1 - cos 1 rad)), energy conservation.
    assert stats.max_speed_m_s == pytest.approx(
        math.sqrt(2 * 9.81 * 0.5 * (1 - math.cos(1.0))), rel=0.02
    )
    assert stats.max_penetration_m == 0.0
    assert 0.0 < stats.min_energy_margin_j <= 1e-3 + 1e-9


def test_body_speeds_match_finite_differences_of_the_centers_of_mass():
    model, data = pendulum()
    mujoco.mj_step(model, data, nstep=300)
    mujoco.mj_forward(model, data)
    before = data.xipos.copy()
    speeds = body_speeds(model, data)
    h = 1e-6
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.opt.timestep = h
    mujoco.mj_step(model, data)
    mujoco.mj_kinematics(model, data)
    fd = np.linalg.norm(data.xipos - before, axis=1)[1:] / h
    assert speeds == pytest.approx(fd, rel=1e-3, abs=1e-6)
    assert speeds[0] > 1.0  # the moving bob, far from its tree's center of mass frame origin


def test_nan_in_the_state_trips_with_reason_and_time():
    model, data = pendulum()
    watchdog = Watchdog(model, data, WatchdogLimits(), 0.0)
    run(model, data, watchdog, 0.1)
    data.qvel[0] = np.nan
    with pytest.raises(WatchdogTripped) as info:
        watchdog.check(model, data)
    assert info.value.reason == "nan_or_inf_state"
    assert info.value.time_s == pytest.approx(0.1, abs=0.011)


def test_mujoco_warning_counter_trips():
    """A huge velocity makes MuJoCo raise its bad-qvel/qacc warning; reported by name."""
    model, data = pendulum()
    watchdog = Watchdog(model, data, WatchdogLimits(), 0.0)
    data.qvel[0] = 1e12
    with pytest.raises(WatchdogTripped) as info:
        run(model, data, watchdog, 0.1)
    assert info.value.reason.startswith("mujoco_warning:bad_q")


def test_speed_beyond_the_bound_trips():
    model, data = pendulum()
    watchdog = Watchdog(model, data, WatchdogLimits(max_speed_m_s=1.0, energy_slack_j=10.0), 0.0)
    with pytest.raises(WatchdogTripped, match="speed") as info:
        run(model, data, watchdog, 2.0)
    assert watchdog.stats.max_speed_m_s > 1.0
    assert 0.0 < info.value.time_s < 0.5  # the bob passes 1 m/s on its first swing


def test_penetration_after_the_grace_time_trips():
    model, data = pendulum()
    box = model.jnt_qposadr[model.body_jntadr[model.body("box").id]]
    data.qpos[box + 2] = 0.05 - 0.01  # 10 mm into the ground
    mujoco.mj_forward(model, data)
    limits = WatchdogLimits(max_penetration_m=0.005, grace_time_s=0.5, energy_slack_j=10.0)
    watchdog = Watchdog(model, data, limits, 0.0)
    mujoco.mj_step(model, data)
    watchdog.check(model, data)  # inside the grace time: no check
    data.qpos[box + 2] = 0.05 - 0.01
    data.time = 0.6
    mujoco.mj_forward(model, data)
    with pytest.raises(WatchdogTripped, match="penetration:10"):
        watchdog.check(model, data)


def test_energy_beyond_the_work_put_in_trips():
    model, data = pendulum()
    watchdog = Watchdog(model, data, WatchdogLimits(energy_slack_j=0.01), actuation_energy_j=0.0)
    run(model, data, watchdog, 0.2)
    data.qvel[0] *= 1.5  # energy from nowhere, speed still within bounds
    with pytest.raises(WatchdogTripped, match="energy"):
        watchdog.check(model, data)


def test_buoyancy_potential_makes_energy_conserved():
    """gravcomp = 3: net upward force 2 m g; kinetic + gravity + buoyancy potential is constant."""
    model, data = pendulum(gravcomp=3.0, box=False)
    energy0 = mechanical_energy(model, data)
    swing = []
    while data.time < 1.0:
        mujoco.mj_step(model, data, nstep=10)
        swing.append(data.qpos[0])
        assert mechanical_energy(model, data) == pytest.approx(energy0, abs=1e-6)
    assert max(swing) > 2.0  # it swung up over the top: the conserved quantity is not trivial


def test_mocap_lift_raises_the_bound():
    """Hub rise and speed add M g H and M v^2 / 2 to the bound."""
    spec = mujoco.MjSpec()
    hub = spec.worldbody.add_body(name="hub", pos=(0, 0, 1), mocap=True)
    hub.add_geom(size=(0.01, 0, 0), contype=0, conaffinity=0)
    bob = spec.worldbody.add_body(name="bob", pos=(0.2, 0, 1))
    bob.add_freejoint()
    bob.add_geom(size=(0.01, 0, 0), mass=0.5, contype=0, conaffinity=0)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    watchdog = Watchdog(model, data, WatchdogLimits(energy_slack_j=0.0), 0.0)
    bound0 = watchdog.energy_bound_j
    data.mocap_pos[0, 2] += 0.1
    data.time += 0.1
    mujoco.mj_forward(model, data)
    watchdog.check(model, data)
    assert watchdog.energy_bound_j - bound0 == pytest.approx(0.5 * 9.81 * 0.1 + 0.5 * 0.5 * 1.0**2)


def _stiff_spec():
    """E = 10 MPa, 16 segments at 6 ms (short sequence, fast preset): unstable; at 3 ms, stable."""
    from entangle_bench.runner import TrialSpec
    from entangle_bench.suite import SHORT_SEQUENCE as SHORT
    from entangle_bench.suite import resolve_config

    stiff = [
        "gripper.filament.youngs_modulus_pa=1e7",
        "gripper.pressure_pa=1.72e6",
        "gripper.filament.n_segments=16",
        "numerics.timestep_s=0.006",
    ]
    config = resolve_config("eight_branch_tree", "fast", SHORT + stiff)
    return TrialSpec("top_drape/eight_branch_tree", "stiff", config, 0, "fast")


def test_unstable_trial_is_never_scored_and_the_half_timestep_retry_says_so(tmp_path):
    """E = 10 MPa, 16 segments at 6 ms: outside the envelope and unstable; at 3 ms, stable. The retry's saved
    states lie under the trial's id (the row's), not under the halved config's, and its recording replaces
    the unstable run's."""
    from mcap.reader import make_reader

    from entangle_bench.recording import read_recording
    from entangle_bench.runner import Watch, run_trial
    from entangle_bench.stability import envelope_warnings

    spec = _stiff_spec()
    assert any("timestep" in w for w in envelope_warnings(spec.config))
    row = run_trial(spec)
    assert row["outcome"] == "unstable" and row["success"] is False and row["failure_mode"] == ""
    assert row["unstable_reason"] and 0.0 < row["unstable_time_s"] < row["sim_time_s"] + 1e-9
    assert row["retried_half_timestep"] is False
    retried = run_trial(spec, retry_unstable=True, folder=tmp_path, watch=Watch(record=True))
    assert retried["retried_half_timestep"] is True
    saved = [p.name for p in (tmp_path / "states").iterdir()]
    assert saved and all(name.startswith(f"{spec.trial_id}_") for name in saved)
    snapshots = {name.removeprefix(f"{spec.trial_id}_").removesuffix(".npz") for name in saved} - {"series"}
    assert all(any(key.startswith(f"{snap}.") for key in retried) for snap in snapshots)
    assert retried["first_unstable_reason"] == row["unstable_reason"]
    assert retried["first_unstable_time_s"] == row["unstable_time_s"]
    assert retried["outcome"] in ("success", "failure")
    (recording,) = (tmp_path / "recordings").iterdir()
    assert recording.name == f"{spec.trial_id}.mcap"
    with open(recording, "rb") as handle:
        metadata = {m.name: m.metadata for m in make_reader(handle).iter_metadata()}
    assert metadata["trial"]["timestep_s"] == "0.003" and metadata["result"]["outcome"] == retried["outcome"]
    last = list(read_recording(recording))[-1]["time_s"]
    assert retried["sim_time_s"] - 0.05 - 1e-9 <= last <= retried["sim_time_s"] and last > row["unstable_time_s"]


def test_a_rerun_with_retry_unstable_retries_the_logged_unstable_trials_and_its_row_replaces_theirs(tmp_path):
    from entangle_bench.executors import make_executor
    from entangle_bench.results import TrialLog
    from entangle_bench.runner import run_trial, run_trials

    spec = _stiff_spec()
    log = TrialLog(tmp_path / "trials.jsonl")
    log.append(run_trial(spec))
    assert log.rows()[0]["outcome"] == "unstable" and log.done_ids() == {spec.trial_id}
    assert run_trials([spec], log, make_executor(1), progress=False) == []  # without the flag: done
    assert log.done_ids(retry_unstable=True) == set()
    assert log.resume_state(retry_unstable=True)[1] == {spec.trial_id: log.rows()[0]}  # the row to retry
    assert log.resume_state()[1] == {}
    (new,) = run_trials([spec], log, make_executor(1), retry_unstable=True, progress=False)
    assert new["retried_half_timestep"] is True and new["outcome"] in ("success", "failure")
    (row,) = TrialLog(log.path).rows()
    assert row["outcome"] == new["outcome"] and row["retried_half_timestep"] is True
    assert log.done_ids(retry_unstable=True) == {spec.trial_id}
    assert run_trials([spec], log, make_executor(1), retry_unstable=True, progress=False) == []


def test_a_logged_unstable_trial_goes_straight_to_the_retry_and_scores_as_a_fresh_retry(tmp_path):
    """A trial is deterministic, so the retry of a logged `unstable` row skips the first attempt: the only run
    made is at half the timestep, and its row equals a fresh run's retry (a second method) in every result
    column; its wall time includes the logged attempt's."""
    from entangle_bench.executors import make_executor
    from entangle_bench.results import TrialLog
    from entangle_bench.runner import run_trial, run_trials

    spec = _stiff_spec()
    log = TrialLog(tmp_path / "trials.jsonl")
    first = run_trial(spec)
    log.append(first)
    timesteps: list[float] = []

    class Timesteps:
        def start(self, env):
            timesteps.append(env.physics.model.opt.timestep)

        def step(self, env):
            pass

        def finish(self, row, complete):
            pass

    (new,) = run_trials([spec], log, make_executor(1), retry_unstable=True, progress=False,
                        observers=lambda _spec: [Timesteps()])
    assert timesteps == [0.003]
    fresh = run_trial(spec, retry_unstable=True)
    assert fresh["retried_half_timestep"] is True
    assert new["wall_time_s"] >= first["wall_time_s"]
    assert {k: v for k, v in new.items() if k != "wall_time_s"} == {
        k: v for k, v in fresh.items() if k != "wall_time_s"}
