"""Suite files (`tasks/*.toml`): named sets of trial conditions, turned into TrialSpecs at once.

A suite file holds:

    description = "what it measures"
    trials = 10            # seeded trials per condition (seeds seed, seed+1, ...)
    preset = "balanced"    # numerical preset (optional; default presets.DEFAULT_PRESET)
    seed = 0               # first seed (optional)
    set = { "contact.friction" = 2.0 }     # optional overrides of every condition (dotted config paths)

    [[conditions]]         # one or more
    task = "eight_branch_tree"
    label = "tree"         # optional
    set = { "phases.hold_time_s" = 2.0 }   # optional overrides of this condition, after the suite's `set`

    [sweep]                # optional: every condition is crossed with the product of these axes
    offset_m = [0.0, 0.01, 0.02]

Errors name the file, the key and the problem. Suite files are found in `tasks/` and looked up through the
`SUITES` registry; `task_suite` makes the same kind of `Suite` for one task from command-line settings, and
both build their trial specs in `_expand`, the one place TrialSpecs are made.
"""

from __future__ import annotations

import itertools
import tomllib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from entangle_bench import resources
from entangle_bench.config import apply_overrides, replace_path
from entangle_bench.errors import EntangleBenchError, FileFormatError, ParameterError, UnknownNameError
from entangle_bench.presets import DEFAULT_PRESET, PRESETS
from entangle_bench.registry import Registry
from entangle_bench.runner import TrialSpec
from entangle_bench.suite import TASKS, resolve_config

SUITE_DIR = resources.tasks_dir()
TOP_KEYS = {"description", "trials", "preset", "seed", "set", "conditions", "sweep"}
CONDITION_KEYS = {"task", "label", "set"}

#: Suite files of `tasks/` by name (the file stem).
SUITES: Registry[Path] = Registry("suite")
for _path in sorted(SUITE_DIR.glob("*.toml")):
    SUITES.add(_path.stem, _path, description="")


@dataclass(frozen=True)
class Suite:
    """A named set of trials: the conditions' trial specs and the swept parameter names."""

    name: str
    description: str
    preset: str
    sweep: tuple[str, ...]
    specs: tuple[TrialSpec, ...]


def suite_path(name: str) -> Path:
    """Path of a suite given by registered name or by a path to a .toml file; unknown names list the known ones."""
    path = Path(name)
    if path.suffix == ".toml" and path.exists():
        return path
    return SUITES.get(name)


def _fail(path: Path, key: str, problem: str) -> FileFormatError:
    return FileFormatError(f"{path}: key {key!r}: {problem}")


def _value(value: Any) -> Any:
    """TOML lists become tuples (config fields are tuples)."""
    return tuple(value) if isinstance(value, list) else value


def _parameter_error(key: str, problem: str) -> ParameterError:
    return ParameterError(f"{key}: {problem}")


def _expand(
    task: str,
    label: str,
    config: Any,
    sweep: dict[str, Sequence[Any]],
    trials: int,
    seed: int,
    preset: str,
    fail: Callable[[str, str], EntangleBenchError] = _parameter_error,
) -> list[TrialSpec]:
    """Trial specs of one condition: `config` crossed with the product of the `sweep` axes, seeds seed, seed + 1..."""
    specs = []
    for combo in itertools.product(*sweep.values()) if sweep else [()]:
        swept = config
        params = tuple(zip(sweep.keys(), combo))
        for key, value in params:
            try:
                swept = replace_path(swept, key, _value(value))
            except (EntangleBenchError, TypeError) as exc:
                raise fail(f"sweep.{key}", str(exc)) from None
        name = " ".join([label] + [f"{k}={v}" for k, v in params])
        row_params = tuple((f"param.{k}", v) for k, v in params)
        specs += [TrialSpec(task, name, swept, seed + k, preset, row_params) for k in range(trials)]
    return specs


def _apply_table(path: Path, where: str, settings: object, config: Any, context: str = "") -> Any:
    """`config` with a suite file's `set` table (dotted.path = value) applied; errors name the file and key."""
    if not isinstance(settings, dict):
        raise _fail(path, where, "must be a table of dotted.path = value")
    for key, value in settings.items():
        try:
            config = replace_path(config, key, _value(value))
        except (EntangleBenchError, TypeError) as exc:
            raise _fail(path, f"{where}.{key}", f"{exc}{context}") from None
    return config


def load_suite(
    name: str,
    trials: int | None = None,
    *,
    preset: str | None = None,
    overrides: Sequence[str] = (),
    offsets: Sequence[float] | None = None,
    seed: int | None = None,
) -> Suite:
    """Read a suite file (registered name or path) into its trial specs, with command-line settings on top.

    `trials`, `preset` and `seed` replace the file's values; `overrides` (`a.b=value`) apply to every condition
    after the suite's `set` and its own; `offsets` (m) replace the `offset_m` sweep axis (or add one). An
    override of a swept parameter is refused: the sweep would replace it.
    """
    path = suite_path(name)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise FileFormatError(f"{path}: not valid TOML: {exc}") from None
    unknown = set(data) - TOP_KEYS
    if unknown:
        raise _fail(path, sorted(unknown)[0], f"unknown key; allowed: {sorted(TOP_KEYS)}")
    count = data.get("trials", 1) if trials is None else trials
    if not isinstance(count, int) or count < 1:
        raise _fail(path, "trials", f"must be a positive integer, got {count!r}")
    if preset is None:
        preset = data.get("preset", DEFAULT_PRESET)
        if preset not in PRESETS:
            raise _fail(path, "preset", f"unknown preset {preset!r}; known: {PRESETS.names()}")
    elif preset not in PRESETS:
        raise UnknownNameError("preset", preset, PRESETS.names())
    seed0 = data.get("seed", 0) if seed is None else seed
    if not isinstance(seed0, int) or seed0 < 0:
        raise _fail(path, "seed", f"must be a non-negative integer, got {seed0!r}")
    conditions = data.get("conditions")
    if not isinstance(conditions, list) or not conditions:
        raise _fail(path, "conditions", "must be a non-empty array of tables ([[conditions]])")
    sweep = data.get("sweep", {})
    if not isinstance(sweep, dict) or any(not isinstance(v, list) or not v for v in sweep.values()):
        raise _fail(path, "sweep", "must be a table of non-empty lists")
    if offsets is not None:
        sweep = {**sweep, "offset_m": [float(x) for x in offsets]}
    for item in overrides:
        key = item.partition("=")[0].strip()
        if key in sweep:
            raise ParameterError(f"--set {key}: suite {path.stem!r} sweeps {key} over {sweep[key]}, which would "
                                 "replace the value" + ("; use --offsets to change the offsets" if key == "offset_m"
                                                        else ""))
    shared = data.get("set", {})
    specs = []
    for n, cond in enumerate(conditions):
        where = f"conditions[{n}]"
        if not isinstance(cond, dict) or "task" not in cond:
            raise _fail(path, where, "each condition needs a 'task'")
        extra = set(cond) - CONDITION_KEYS
        if extra:
            raise _fail(path, f"{where}.{sorted(extra)[0]}", f"unknown key; allowed: {sorted(CONDITION_KEYS)}")
        try:
            task = TASKS.entry(cond["task"]).value.name
        except UnknownNameError as exc:
            raise _fail(path, f"{where}.task", str(exc)) from None
        base = resolve_config(task, preset)
        base = _apply_table(path, "set", shared, base, f" (condition {where}, task {task})")
        base = _apply_table(path, f"{where}.set", cond.get("set", {}), base)
        try:
            base = apply_overrides(base, overrides)
        except (EntangleBenchError, TypeError) as exc:
            raise ParameterError(f"--set on suite {path.stem}, condition {where} (task {task}): {exc}") from None
        label = cond.get("label", task.split("/")[-1])
        specs += _expand(task, label, base, sweep, count, seed0, preset, lambda k, p: _fail(path, k, p))
    return Suite(path.stem, data.get("description", ""), preset, tuple(sweep), tuple(specs))


def task_suite(
    task: str,
    *,
    preset: str | None = None,
    overrides: Iterable[str] = (),
    offsets: Sequence[float] | None = None,
    trials: int = 1,
    seed: int = 0,
) -> Suite:
    """A suite of one task from command-line settings: preset, `a.b=value` overrides, offsets (m), trials, seed.

    Tasks with a centering offset sweep `offset_m` (over `offsets`, or the resolved config's own offset).
    """
    name = TASKS.entry(task).value.name
    preset = preset or DEFAULT_PRESET
    base = resolve_config(name, preset, overrides)
    if offsets is None and hasattr(base, "offset_m"):
        offsets = [base.offset_m]
    sweep = {} if offsets is None else {"offset_m": [float(x) for x in offsets]}
    specs = _expand(name, name.split("/")[-1], base, sweep, trials, seed, preset)
    return Suite(task.replace("/", "_"), "", preset, tuple(sweep), tuple(specs))
