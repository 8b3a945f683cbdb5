"""Task registry: tasks are registered by (domain, name) and loaded like `dm_control.suite.load`.

    env = load("top_drape", "eight_branch_tree", offset=0.01, seed=3)

The `top_drape` domain has one task per object in the object library. Each entry holds its default
configuration factory and tags; duplicates raise, unknown names raise an error listing the known ones.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable
from dataclasses import dataclass

from dm_control.rl import control

from entangle_bench import objects
from entangle_bench.config import apply_overrides
from entangle_bench.errors import ParameterError, UnknownNameError
from entangle_bench.presets import DEFAULT_PRESET, get_preset
from entangle_bench.suite.top_drape import TopDrapeConfig, make_environment


@dataclass(frozen=True)
class TaskEntry:
    """One registered task."""

    domain: str
    name: str
    default_config: Callable[[], TopDrapeConfig]
    tags: tuple[str, ...]
    description: str

    @property
    def full_name(self) -> str:
        """'domain/name'."""
        return f"{self.domain}/{self.name}"


class Registry:
    """Tasks by 'domain/name'."""

    def __init__(self) -> None:
        self._entries: dict[str, TaskEntry] = {}

    def add(self, entry: TaskEntry) -> None:
        """Register a task; a duplicate name raises ValueError."""
        if entry.full_name in self._entries:
            raise ValueError(f"task {entry.full_name!r} is already registered")
        self._entries[entry.full_name] = entry

    def get(self, full_name: str) -> TaskEntry:
        """Entry by 'domain/name' (a bare object name means 'top_drape/<name>')."""
        key = full_name if "/" in full_name else f"top_drape/{full_name}"
        try:
            return self._entries[key]
        except KeyError:
            raise UnknownNameError("task", full_name, list(self._entries)) from None

    def names(self, tag: str | None = None) -> list[str]:
        """Registered 'domain/name' strings, optionally only those with `tag`."""
        return sorted(k for k, e in self._entries.items() if tag is None or tag in e.tags)


TASKS = Registry()

#: Overrides for a short top-drape sequence (about 2.7 s simulated instead of 7.6 s): smoke tests, CI and
#: quick benchmarks. Use with `resolve_config(task, preset, SHORT_SEQUENCE + [...])`.
SHORT_SEQUENCE = [
    "phases.drape_depth_m=0.03",
    "phases.ramp_time_s=0.2",
    "phases.settle_time_s=0.1",
    "phases.lift_height_m=0.03",
    "phases.lift_speed_m_s=0.1",
    "phases.hold_time_s=0.3",
    "phases.release_time_s=0.1",
]


def _object_task_config(object_name: str) -> Callable[[], TopDrapeConfig]:
    def default_config() -> TopDrapeConfig:
        return TopDrapeConfig(object_name=object_name, object=objects.default_params(object_name))

    return default_config


for _name in objects.names():
    TASKS.add(
        TaskEntry(
            domain="top_drape",
            name=_name,
            default_config=_object_task_config(_name),
            tags=("benchmark",) + (("mesh",) if objects.is_mesh_object(_name) else ()),
            description=f"top-drape lift-and-hold of {_name}: {objects.description(_name)}",
        )
    )


def resolve_config(
    task: str,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    offset: float | None = None,
) -> TopDrapeConfig:
    """Default config of `task` with a numerical preset, `a.b=value` overrides and an offset (m) applied."""
    config = TASKS.get(task).default_config()
    chosen = get_preset(preset or DEFAULT_PRESET)
    filament = dataclasses.replace(config.gripper.filament, n_segments=chosen.n_segments)
    config = dataclasses.replace(
        config,
        gripper=dataclasses.replace(config.gripper, filament=filament),
        numerics=chosen.numerics,
    )
    try:
        config = apply_overrides(config, overrides)
        if offset is not None:
            config = dataclasses.replace(config, offset_m=float(offset))
    except TypeError as exc:
        raise ParameterError(f"invalid override for task {task}: {exc}") from None
    return config


def load(
    domain: str,
    task: str,
    *,
    seed: int = 0,
    offset: float | None = None,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    config: TopDrapeConfig | None = None,
) -> control.Environment:
    """Load a registered task as a dm-control environment (offset in m; seed drives all randomness)."""
    entry = TASKS.get(f"{domain}/{task}")
    if config is None:
        config = resolve_config(entry.full_name, preset, overrides, offset)
    return make_environment(config, seed)
