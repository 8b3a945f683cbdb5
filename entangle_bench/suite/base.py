"""The benchmark task API: the base class of every task family, the outcome it decides, and the task registry.

A task is a dm_control `suite.base.Task`: it initializes episodes, computes observations and reward, and never
steps the physics. The runner (`entangle_bench.runner`) owns the step loop and the watchdog. Per control step
a task acts through dm_control's hooks (`before_step`, `after_step`, `get_termination`); to the runner it
declares:

* `PHASES` and `phase(physics)`: the named phases of its sequence and the one the next control step runs in;
* `SNAPSHOTS`: snapshot name -> phase at whose start the runner takes `snapshot(physics)` (row columns
  `<name>.<metric>`, arrays saved as `states/<trial_id>_<name>.npz`);
* `metrics(physics)`: named numbers for the results row (MuJoCo Playground style: every term by name);
* `series_point(physics)`: named numbers the runner logs after every control step (saved beside the states);
* `scripted_action(physics)`: the open-loop reference policy;
* `actuation_energy_j()` and `watchdog_limits()`: what the watchdog needs;
* `outcome`: decided once, by the task, through `decide`; reward, row and summary read it.

Task families register each task with `register_task` next to its default configuration:

    @register_task("probe/curl_in_air", config_type=ProbeConfig, make_environment=make_environment)
    def curl_in_air() -> ProbeConfig:
        \"\"\"Three filaments curling into each other in air.\"\"\"
        return ProbeConfig()
"""

from __future__ import annotations

import abc
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, Literal, TypeVar

import numpy as np
from dm_control.rl import control
from dm_control.suite import base

from entangle_bench.errors import OutcomeError, UnknownNameError
from entangle_bench.registry import Entry, Registry, first_line
from entangle_bench.watchdog import WatchdogLimits

C = TypeVar("C")

#: Domain of task names given without one ('eight_branch_tree' means 'top_drape/eight_branch_tree').
DEFAULT_DOMAIN = "top_drape"


@dataclass(frozen=True)
class Outcome:
    """A task's decision about one trial, made once: success or failure, why, and the numbers it rests on."""

    status: Literal["success", "failure"]
    failure_mode: str = ""
    """'' on success; otherwise the task's name for how it failed (e.g. 'never_lifted')."""
    decided_at_s: float = 0.0
    """Simulated time of the decision, s."""
    evidence: Mapping[str, float] = field(default_factory=dict)
    """The numbers the decision rests on, by name (SI units in the names)."""

    @property
    def success(self) -> bool:
        """Whether the trial succeeded."""
        return self.status == "success"


@dataclass(frozen=True, eq=False)
class Snapshot:
    """The state at a snapshot point: named numbers for the row and arrays saved beside it."""

    metrics: dict[str, float]
    arrays: dict[str, np.ndarray]


class BenchTask(base.Task, Generic[C]):
    """Base class of benchmark tasks: config, seeded generator, phases, snapshots, metrics and one outcome."""

    #: Names of the phases of the task's sequence, in order.
    PHASES: ClassVar[tuple[str, ...]] = ()
    #: Snapshot name -> phase at whose start the runner takes it.
    SNAPSHOTS: ClassVar[Mapping[str, str]] = {}

    def __init__(self, config: C, seed: int):
        super().__init__(random=seed)
        self.config = config
        self.seed = seed
        self.rng = np.random.default_rng(seed)
        self._outcome: Outcome | None = None

    @property
    def outcome(self) -> Outcome | None:
        """The decided outcome, None until the task has decided."""
        return self._outcome

    def decide(self, outcome: Outcome) -> None:
        """Record the outcome; deciding twice in one episode raises OutcomeError."""
        if self._outcome is not None:
            raise OutcomeError(f"{type(self).__name__} decided its outcome twice: {self._outcome} then {outcome}")
        self._outcome = outcome

    def initialize_episode(self, physics: Any) -> None:
        """Forget the previous episode's outcome (subclasses set up the scene, then call this)."""
        self._outcome = None

    def get_reward(self, physics: Any) -> float:
        """1 once the task has decided the trial a success, else 0."""
        return float(self._outcome is not None and self._outcome.success)

    @abc.abstractmethod
    def phase(self, physics: Any) -> str:
        """Name of the phase (one of PHASES) the next control step runs in."""

    @abc.abstractmethod
    def scripted_action(self, physics: Any) -> np.ndarray:
        """The open-loop reference policy's action at the current time (units of `action_spec`)."""

    @abc.abstractmethod
    def actuation_energy_j(self) -> float:
        """Largest elastic energy the actuation can store, J (the watchdog's W_act)."""

    def metrics(self, physics: Any) -> dict[str, float]:
        """Named numbers for the results row, SI units in the names (none by default)."""
        return {}

    def snapshot(self, physics: Any) -> Snapshot:
        """The state at a snapshot point; tasks that declare SNAPSHOTS implement it."""
        raise NotImplementedError(f"{type(self).__name__} declares snapshots {dict(self.SNAPSHOTS)} but no snapshot()")

    def series_point(self, physics: Any) -> Mapping[str, float]:
        """Named numbers the runner logs after this control step (none by default)."""
        return {}

    def watchdog_limits(self) -> WatchdogLimits:
        """Bounds beyond which the runner calls a trial of this task unstable."""
        return WatchdogLimits()


@dataclass(frozen=True)
class TaskDef(Generic[C]):
    """How to build one registered task: config type, default config and environment factory."""

    name: str
    """'domain/name'."""
    config_type: type[C]
    default_config: Callable[[], C]
    make_environment: Callable[[C, int], control.Environment]
    """(config, seed) -> the dm-control environment of one trial."""

    @property
    def domain(self) -> str:
        """The task family ('top_drape', 'probe', ...)."""
        return self.name.split("/", 1)[0]


class TaskRegistry(Registry[TaskDef[Any]]):
    """Tasks by 'domain/name'; a bare name means the default domain (DEFAULT_DOMAIN), 'domain_name' domain/name."""

    def resolve(self, name: str) -> str:
        """The registered 'domain/name' that `name` means: itself, 'top_drape/<name>' or, for
        '<domain>_<rest>' with a registered domain, '<domain>/<rest>' (e.g. 'pullout_sphere'); unknown names raise
        UnknownNameError listing the known ones."""
        candidates = [name] if "/" in name else [f"{DEFAULT_DOMAIN}/{name}"]
        if "/" not in name:
            domains = {known.split("/", 1)[0] for known in self}
            candidates += [f"{d}/{name[len(d) + 1 :]}" for d in sorted(domains) if name.startswith(f"{d}_")]
        for key in candidates:
            if key in self:
                return key
        raise UnknownNameError(self.kind, name, self.names())

    def entry(self, name: str) -> Entry[TaskDef[Any]]:
        """Entry of a task name as `resolve` reads it."""
        return super().entry(self.resolve(name))


TASKS = TaskRegistry("task")


def register_task(
    name: str,
    *,
    config_type: type[C],
    make_environment: Callable[[C, int], control.Environment],
    tags: Iterable[str] = (),
    description: str | None = None,
) -> Callable[[Callable[[], C]], Callable[[], C]]:
    """Decorator: register a default-config function as task `name` ('domain/name') built by `make_environment`.

    The description defaults to the first line of the function's docstring.
    """

    def decorate(default_config: Callable[[], C]) -> Callable[[], C]:
        TASKS.add(
            name,
            TaskDef(name, config_type, default_config, make_environment),
            tags=tags,
            description=description if description is not None else first_line(default_config),
        )
        return default_config

    return decorate
