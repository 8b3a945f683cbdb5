"""One registry mechanism for everything looked up by name: tasks, objects, presets, suites, representations.

A `Registry` maps names to values of one type, with tags and a one-line description per entry. Entries are
added next to the thing they name, usually with the decorator:

    REPRESENTATIONS: Registry[Builder] = Registry("representation")

    @REPRESENTATIONS.register("ball", tags=("harness",))
    def build_ball(case, n_segments, numerics, damping_time_s): ...

or with `add(name, value)` when a loop registers many. A duplicate name raises `DuplicateNameError`; an unknown
name raises `UnknownNameError` listing the known ones (both `entangle_bench.errors`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Generic, TypeVar

from entangle_bench.errors import DuplicateNameError, UnknownNameError

T = TypeVar("T")


@dataclass(frozen=True)
class Entry(Generic[T]):
    """One registered value with its name, tags and one-line description."""

    name: str
    value: T
    tags: tuple[str, ...] = ()
    description: str = ""


def first_line(obj: object) -> str:
    """First line of an object's docstring ('' if it has none)."""
    doc = getattr(obj, "__doc__", None) or ""
    return doc.strip().splitlines()[0] if doc.strip() else ""


class Registry(Generic[T]):
    """Values of one kind by name; `kind` names the kind in error messages ('task', 'preset', ...)."""

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._entries: dict[str, Entry[T]] = {}

    def add(self, name: str, value: T, *, tags: Iterable[str] = (), description: str | None = None) -> T:
        """Register `value` under `name` and return it; the description defaults to its docstring's first line."""
        if name in self._entries:
            raise DuplicateNameError(self.kind, name)
        text = first_line(value) if description is None else description
        self._entries[name] = Entry(name, value, tuple(tags), text)
        return value

    def register(
        self, name: str, *, tags: Iterable[str] = (), description: str | None = None
    ) -> Callable[[T], T]:
        """Decorator form of `add`: registers the decorated object under `name` and returns it unchanged."""

        def decorate(value: T) -> T:
            return self.add(name, value, tags=tags, description=description)

        return decorate

    def entry(self, name: str) -> Entry[T]:
        """The entry of `name`; an unknown name raises UnknownNameError listing the known ones."""
        try:
            return self._entries[name]
        except KeyError:
            raise UnknownNameError(self.kind, name, list(self._entries)) from None

    def get(self, name: str) -> T:
        """The value registered under `name`; an unknown name raises UnknownNameError."""
        return self.entry(name).value

    def names(self, tag: str | None = None) -> list[str]:
        """Registered names, sorted; only those carrying `tag` if given."""
        return sorted(n for n, e in self._entries.items() if tag is None or tag in e.tags)

    def items(self) -> list[tuple[str, T]]:
        """(name, value) pairs in registration order."""
        return [(n, e.value) for n, e in self._entries.items()]

    def values(self) -> list[T]:
        """Registered values in registration order."""
        return [e.value for e in self._entries.values()]

    def __getitem__(self, name: str) -> T:
        return self.get(name)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._entries))

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {len(self)} entries)"
