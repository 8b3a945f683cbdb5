"""Where a trial's time goes: MuJoCo's stage timers (`mjData.timer`) and solver load, per task phase.

`StageProfile` is an observer (`observers.Observer`): after every control step it moves the time MuJoCo's
timers accumulated since the last step into the phase that step ran in, with the wall time of the whole
control step (the Python between steps included), the contact count and the solver's iterations (summed over
the constraint islands, `solver_load`). Use
it through `profile_trial`, or pass it to `runner.simulate(..., observers=[...])`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import mujoco
import pandas as pd

from entangle_bench.runner import TrialResult, simulate

#: Stages reported, by MuJoCo timer: the whole step, then its parts that dominate filament trials.
STAGES: dict[str, mujoco.mjtTimer] = {
    "step": mujoco.mjtTimer.mjTIMER_STEP,
    "position": mujoco.mjtTimer.mjTIMER_POSITION,
    "collision": mujoco.mjtTimer.mjTIMER_POS_COLLISION,
    "make_constraint": mujoco.mjtTimer.mjTIMER_POS_MAKE,
    "inertia": mujoco.mjtTimer.mjTIMER_POS_INERTIA,
    "velocity": mujoco.mjtTimer.mjTIMER_VELOCITY,
    "constraint_solver": mujoco.mjtTimer.mjTIMER_CONSTRAINT,
    "advance": mujoco.mjtTimer.mjTIMER_ADVANCE,
}


def solver_load(data: Any) -> tuple[int, float]:
    """The last step's constraint-solver iterations summed over its islands, and the worst island's last relative
    improvement (small: converged). MuJoCo keeps solver statistics per island, for the first mjNISLAND islands
    (slot 0 when islands are off or there are none), so slot 0 alone undercounts a step with several islands."""
    n = min(max(int(data.nisland), 1), mujoco.mjNISLAND)
    niter = [int(k) for k in data.solver_niter[:n]]
    last = [data.solver[i * mujoco.mjNSOLVER + k - 1].improvement for i, k in enumerate(niter) if k]
    return sum(niter), float(max(last, default=0.0))


@dataclass
class _PhaseLoad:
    steps: int = 0
    control_steps: int = 0
    wall_s: float = 0.0
    sim_s: float = 0.0
    contacts: int = 0
    iterations: int = 0
    stage_s: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STAGES, 0.0))

    def add(self, steps: int, wall_s: float, sim_s: float, contacts: int, iterations: int,
            stage_s: dict[str, float]) -> None:
        """Count one control step: physics steps, wall and simulated s, contacts, iterations, stage s."""
        self.steps += steps
        self.control_steps += 1
        self.wall_s += wall_s
        self.sim_s += sim_s
        self.contacts += contacts
        self.iterations += iterations
        for name, seconds in stage_s.items():
            self.stage_s[name] += seconds


class StageProfile:
    """Observer: MuJoCo stage time, wall time, contacts and solver iterations per phase of one trial."""

    def __init__(self) -> None:
        self.phases: dict[str, _PhaseLoad] = {}
        self.total = _PhaseLoad()
        self._last: dict[str, float] = {}
        self._steps = 0
        self._time = 0.0
        self._clock = 0.0

    def _read(self, data: Any) -> dict[str, float]:
        return {name: float(data.timer[int(timer)].duration) for name, timer in STAGES.items()}

    def start(self, env: Any) -> None:
        data = env.physics.data.ptr
        self._last = self._read(data)
        self._steps = int(data.timer[int(mujoco.mjtTimer.mjTIMER_STEP)].number)
        self._time = env.physics.data.time
        self._clock = time.perf_counter()

    def step(self, env: Any) -> None:
        physics = env.physics
        data = physics.data.ptr
        now = self._read(data)
        steps = int(data.timer[int(mujoco.mjtTimer.mjTIMER_STEP)].number)
        clock = time.perf_counter()
        # The step just run belongs to the phase the task is in now, except at a boundary (one step, negligible).
        counted = (
            steps - self._steps,
            clock - self._clock,
            physics.data.time - self._time,
            int(data.ncon),
            solver_load(data)[0],
            {name: now[name] - self._last[name] for name in STAGES},
        )
        for load in (self.phases.setdefault(env.task.phase(physics), _PhaseLoad()), self.total):
            load.add(*counted)
        self._last, self._steps, self._time, self._clock = now, steps, physics.data.time, clock

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to write: the table is read with `table`."""

    def table(self) -> pd.DataFrame:
        """One row per phase (and `all`): wall s per simulated s, µs per physics step, stage shares (%),
        mean contacts and solver iterations at the control steps."""
        rows = []
        loads = {**self.phases, "all": self.total}
        for name, load in loads.items():
            if load.steps == 0 or load.sim_s <= 0:
                continue
            step_s = load.stage_s["step"]
            row = {
                "phase": name,
                "sim_s": load.sim_s,
                "wall_per_sim_s": load.wall_s / load.sim_s,
                "us_per_step": 1e6 * step_s / load.steps,
                "python_share_pct": 100 * max(0.0, 1 - step_s / load.wall_s),
                "mean_contacts": load.contacts / load.control_steps,
                "mean_solver_iterations": load.iterations / load.control_steps,
            }
            for stage in STAGES:
                if stage != "step":
                    row[f"{stage}_pct"] = 100 * load.stage_s[stage] / step_s if step_s > 0 else 0.0
            rows.append(row)
        return pd.DataFrame(rows)


def profile_trial(task: str, config: Any, seed: int = 0) -> tuple[TrialResult, pd.DataFrame]:
    """Run one trial under `StageProfile`; its result and the per-phase table (see `StageProfile.table`)."""
    profile = StageProfile()
    result = simulate(task, config, seed, observers=[profile])
    return result, profile.table()
