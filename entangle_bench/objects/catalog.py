"""The object catalog: every target object by name, registered next to the builder of its shape.

    @register_object("sphere", SphereParams(), "100 mm light hollow ball, 50 g")
    def build_sphere(p: SphereParams) -> Shape: ...

One builder may serve several objects (a tennis ball is a sphere with other parameters). Mesh objects carry
the tag `mesh`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from entangle_bench.objects.geometry import Shape
from entangle_bench.registry import Registry


@dataclass(frozen=True)
class ObjectDef:
    """How to make one named object: its default parameter dataclass and the builder of its shape."""

    default_params: Any
    build: Callable[[Any], Shape]


OBJECTS: Registry[ObjectDef] = Registry("object")


def register_object(
    name: str, default_params: Any, description: str, tags: Iterable[str] = ()
) -> Callable[[Callable[[Any], Shape]], Callable[[Any], Shape]]:
    """Decorator: register the decorated shape builder as object `name` with `default_params`."""

    def decorate(build: Callable[[Any], Shape]) -> Callable[[Any], Shape]:
        OBJECTS.add(name, ObjectDef(default_params, build), tags=tags, description=description)
        return build

    return decorate
