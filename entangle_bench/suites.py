"""Suite files (`tasks/*.toml`): named sets of trial conditions, turned into TrialSpecs at once.

A suite file holds:

    description = "what it measures"
    trials = 10            # seeded trials per condition (seeds seed, seed+1, ...)
    preset = "balanced"    # numerical preset (optional)
    seed = 0               # first seed (optional)

    [[conditions]]         # one or more
    task = "eight_branch_tree"
    label = "tree"         # optional
    set = { "phases.hold_time_s" = 2.0 }   # optional overrides (dotted config paths)

    [sweep]                # optional: every condition is crossed with the product of these axes
    offset_m = [0.0, 0.01, 0.02]

Errors name the file, the key and the problem.
"""

from __future__ import annotations

import itertools
import tomllib
from pathlib import Path
from typing import Any

from entangle_bench import resources
from entangle_bench.config import replace_path
from entangle_bench.errors import EntangleBenchError, FileFormatError, UnknownNameError
from entangle_bench.presets import PRESETS
from entangle_bench.runner import TrialSpec
from entangle_bench.suite import TASKS, resolve_config

SUITE_DIR = resources.tasks_dir()
TOP_KEYS = {"description", "trials", "preset", "seed", "conditions", "sweep"}
CONDITION_KEYS = {"task", "label", "set"}


def suite_names(folder: Path = SUITE_DIR) -> list[str]:
    """Names of the suite files in `folder`."""
    return sorted(p.stem for p in folder.glob("*.toml"))


def suite_path(name: str, folder: Path = SUITE_DIR) -> Path:
    """Path of a suite by name or path; unknown names list the known ones."""
    path = Path(name)
    if path.suffix == ".toml" and path.exists():
        return path
    candidate = folder / f"{name}.toml"
    if candidate.exists():
        return candidate
    raise UnknownNameError("suite", name, suite_names(folder))


def _fail(path: Path, key: str, problem: str) -> FileFormatError:
    return FileFormatError(f"{path}: key {key!r}: {problem}")


def _value(value: Any) -> Any:
    """TOML lists become tuples (config fields are tuples)."""
    return tuple(value) if isinstance(value, list) else value


def load_suite(name: str, trials: int | None = None, folder: Path = SUITE_DIR) -> tuple[dict, list[TrialSpec]]:
    """Read a suite; return its header and the trial specs (`trials` overrides the file's count)."""
    path = suite_path(name, folder)
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
    preset = data.get("preset", "balanced")
    if preset not in PRESETS:
        raise _fail(path, "preset", f"unknown preset {preset!r}; known: {sorted(PRESETS)}")
    seed0 = data.get("seed", 0)
    if not isinstance(seed0, int) or seed0 < 0:
        raise _fail(path, "seed", f"must be a non-negative integer, got {seed0!r}")
    conditions = data.get("conditions")
    if not isinstance(conditions, list) or not conditions:
        raise _fail(path, "conditions", "must be a non-empty array of tables ([[conditions]])")
    sweep = data.get("sweep", {})
    if not isinstance(sweep, dict) or any(not isinstance(v, list) or not v for v in sweep.values()):
        raise _fail(path, "sweep", "must be a table of non-empty lists")
    specs = []
    for n, cond in enumerate(conditions):
        where = f"conditions[{n}]"
        if not isinstance(cond, dict) or "task" not in cond:
            raise _fail(path, where, "each condition needs a 'task'")
        extra = set(cond) - CONDITION_KEYS
        if extra:
            raise _fail(path, f"{where}.{sorted(extra)[0]}", f"unknown key; allowed: {sorted(CONDITION_KEYS)}")
        try:
            task = TASKS.get(cond["task"]).full_name
        except UnknownNameError as exc:
            raise _fail(path, f"{where}.task", str(exc)) from None
        settings = cond.get("set", {})
        if not isinstance(settings, dict):
            raise _fail(path, f"{where}.set", "must be a table of dotted.path = value")
        base = resolve_config(task, preset)
        for key, value in settings.items():
            try:
                base = replace_path(base, key, _value(value))
            except (EntangleBenchError, TypeError) as exc:
                raise _fail(path, f"{where}.set.{key}", str(exc)) from None
        for combo in itertools.product(*sweep.values()) if sweep else [()]:
            config = base
            params = tuple(zip(sweep.keys(), combo))
            for key, value in params:
                try:
                    config = replace_path(config, key, _value(value))
                except (EntangleBenchError, TypeError) as exc:
                    raise _fail(path, f"sweep.{key}", str(exc)) from None
            label = cond.get("label", task.split("/")[-1])
            label = " ".join([label] + [f"{k}={v}" for k, v in params])
            for k in range(count):
                specs.append(
                    TrialSpec(task, label, config, seed0 + k, preset, tuple((f"param.{a}", b) for a, b in params))
                )
    header = {"name": path.stem, "description": data.get("description", ""), "sweep": list(sweep)}
    return header, specs
