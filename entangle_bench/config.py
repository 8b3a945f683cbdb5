"""Helpers for typed, frozen configuration dataclasses: range checks and `a.b=value` overrides."""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any

from entangle_bench.errors import ParameterError


def check_range(
    name: str,
    value: float,
    low: float | None = None,
    high: float | None = None,
    *,
    low_open: bool = False,
    high_open: bool = False,
) -> None:
    """Raise ParameterError unless `low <= value <= high` (open ends when asked); None is unbounded."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ParameterError(f"{name} must be a finite number, got {value!r}")
    bad = (low is not None and (value < low or (low_open and value == low))) or (
        high is not None and (value > high or (high_open and value == high))
    )
    if bad:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        lo = "-inf" if low is None else f"{low:g}"
        hi = "inf" if high is None else f"{high:g}"
        raise ParameterError(f"{name} = {value!r} is outside the allowed range {left}{lo}, {hi}{right}")


def check_choice(name: str, value: Any, allowed: typing.Iterable[Any]) -> None:
    """Raise ParameterError unless `value` is one of `allowed`."""
    allowed = list(allowed)
    if value not in allowed:
        raise ParameterError(f"{name} = {value!r} is not allowed; choose one of {allowed}")


def coerce_text(text: str, annotation: Any, path: str) -> Any:
    """Convert command-line text to the type named by a dataclass field annotation."""
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        if text.lower() == "none" and type(None) in args:
            return None
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return coerce_text(text, arg, path)
            except ParameterError as exc:
                errors.append(str(exc))
        raise ParameterError("; ".join(errors))
    if origin is typing.Literal:
        for choice in args:
            if str(choice) == text:
                return choice
        raise ParameterError(f"{path}: {text!r} is not one of {list(args)}")
    if origin is tuple:
        items = [t for t in text.strip("()[] ").split(",") if t.strip()]
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(coerce_text(t.strip(), args[0], path) for t in items)
        if len(items) != len(args):
            raise ParameterError(f"{path}: expected {len(args)} comma-separated values, got {text!r}")
        return tuple(coerce_text(t.strip(), a, path) for t, a in zip(items, args))
    if annotation is bool:
        lowered = text.lower()
        if lowered in ("1", "true", "yes", "on"):
            return True
        if lowered in ("0", "false", "no", "off"):
            return False
        raise ParameterError(f"{path}: expected a boolean (true/false), got {text!r}")
    if annotation in (int, float, str):
        try:
            return annotation(text)
        except ValueError:
            raise ParameterError(
                f"{path}: expected {annotation.__name__}, got {text!r}"
            ) from None
    raise ParameterError(f"{path}: fields of type {annotation!r} cannot be set from text")


def replace_path(config: Any, path: str, value: Any) -> Any:
    """Return a copy of nested frozen dataclass `config` with dotted field `path` set to `value`.

    `value` may be text (then it is converted to the field's declared type) or an object.
    """
    head, _, rest = path.partition(".")
    if not dataclasses.is_dataclass(config):
        raise ParameterError(f"cannot set {path!r}: {type(config).__name__} has no fields")
    hints = typing.get_type_hints(type(config))
    names = [f.name for f in dataclasses.fields(config)]
    if head not in names:
        raise ParameterError(
            f"unknown setting {head!r} in {type(config).__name__}; known: {', '.join(names)}"
        )
    if rest:
        new = replace_path(getattr(config, head), rest, value)
    elif isinstance(value, str) and hints[head] is not str:
        new = coerce_text(value, hints[head], head)
    else:
        new = value
    return dataclasses.replace(config, **{head: new})


def apply_overrides(config: Any, overrides: typing.Iterable[str]) -> Any:
    """Apply `a.b=value` strings to a frozen dataclass, checking names and types.

    Overrides of fields of one dataclass are applied together (one `dataclasses.replace`), so fields that are
    only valid together (e.g. `gripper.ring_diameters_m` and `gripper.ring_counts`) can be changed at once;
    a later override of the same field wins.
    """
    tree: dict[str, Any] = {}
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ParameterError(f"override {item!r} must look like name.field=value")
        *parents, leaf = key.strip().split(".")
        node = tree
        for name in parents:
            node = node.setdefault(name, {})
            if not isinstance(node, dict):
                raise ParameterError(f"override {item!r}: {name!r} is set as a value and as a group")
        node[leaf] = value.strip()
    return _replace_tree(config, tree, "")


def _replace_tree(config: Any, tree: dict[str, Any], prefix: str) -> Any:
    """`config` with the fields in `tree` (text values or nested trees) replaced in one step per dataclass."""
    if not dataclasses.is_dataclass(config):
        raise ParameterError(f"cannot set '{prefix}{next(iter(tree))}': {type(config).__name__} has no fields")
    hints = typing.get_type_hints(type(config))
    names = [f.name for f in dataclasses.fields(config)]
    changes = {}
    for name, value in tree.items():
        if name not in names:
            raise ParameterError(
                f"unknown setting '{prefix}{name}' in {type(config).__name__}; known: {', '.join(names)}"
            )
        if isinstance(value, dict):
            changes[name] = _replace_tree(getattr(config, name), value, f"{prefix}{name}.")
        elif hints[name] is not str:
            changes[name] = coerce_text(value, hints[name], f"{prefix}{name}")
        else:
            changes[name] = value
    return dataclasses.replace(config, **changes)


def to_flat_dict(config: Any, prefix: str = "") -> dict[str, Any]:
    """Flatten a nested dataclass into {'a.b': value} for result rows."""
    out: dict[str, Any] = {}
    for field in dataclasses.fields(config):
        value = getattr(config, field.name)
        key = f"{prefix}{field.name}"
        if dataclasses.is_dataclass(value):
            out.update(to_flat_dict(value, key + "."))
        else:
            out[key] = value
    return out
