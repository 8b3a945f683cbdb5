"""Object library: target objects by name (trees, primitives, Dex-Net meshes) and how to add one
to a MuJoCo scene. See registry.py for the body-frame convention."""

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
    "BuiltObject",
    "ObjectInfo",
    "add_object",
    "build",
    "clear_build_cache",
    "default_params",
    "description",
    "is_mesh_object",
    "names",
    "object_info",
]
