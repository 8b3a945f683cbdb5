"""Object library: target objects by name (trees, primitives, Dex-Net meshes) and how to add one
to a MuJoCo scene. Objects register in `catalog.OBJECTS` next to their builders; see registry.py for the
body-frame convention."""

from entangle_bench.objects.catalog import OBJECTS, ObjectDef, register_object
from entangle_bench.objects.registry import (
    BuiltObject,
    ObjectInfo,
    add_object,
    build,
    clear_build_cache,
    default_params,
    description,
    is_mesh_object,
    names,
    object_info,
)

__all__ = [
    "OBJECTS",
    "BuiltObject",
    "ObjectDef",
    "ObjectInfo",
    "add_object",
    "build",
    "clear_build_cache",
    "default_params",
    "description",
    "is_mesh_object",
    "names",
    "object_info",
    "register_object",
]
