"""`entangle-bench objects list|show|decompose`: inspect the object library and decompose meshes."""

from __future__ import annotations

import argparse
import dataclasses
import os
from pathlib import Path

from entangle_bench import objects
from entangle_bench.config import apply_overrides
from entangle_bench.errors import UnknownNameError
from entangle_bench.objects import meshes
from entangle_bench.objects.geometry import ConvexMesh, union_moments


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Attach the `objects` subcommand and its actions."""
    parser = subparsers.add_parser("objects", help="list, show and decompose target objects")
    parser.set_defaults(run=run)
    actions = parser.add_subparsers(dest="action", required=True)
    actions.add_parser("list", help="every object with its size, mass, phi_T and parts")
    show = actions.add_parser("show", help="one object's dimensions, mass, phi_T and a picture")
    show.add_argument("name")
    show.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                      help="override a parameter, e.g. branch_length_m=0.06 (repeatable)")
    show.add_argument("--out", default=None,
                      help="PNG path for the picture (default results/scratch/objects/NAME.png)")
    dec = actions.add_parser("decompose", help="convex decomposition (CoACD) of a mesh object "
                                                "or mesh file, cached (see entangle_bench.resources)")
    dec.add_argument("target", help="object name or mesh file path")
    dec.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                     help="override a parameter, e.g. coacd.threshold=0.04 (repeatable)")
    dec.add_argument("--scale", type=float, default=None,
                     help="scale factor applied to a mesh file (e.g. 0.001 for millimetres)")
    dec.add_argument("--cache-dir", default=None,
                     help="cache folder (default: committed caches, then ~/.cache/entangle-bench/coacd)")
    dec.add_argument("--force", action="store_true", help="recompute even if cached")


def _params(name: str, overrides: list[str]):
    """Default params of `name` with `--set` overrides applied."""
    return apply_overrides(objects.default_params(name), overrides)


def _list() -> int:
    print(f"{'name':22s} {'mass g':>7s} {'height mm':>9s} {'radius mm':>9s} {'vol cm3':>8s} "
          f"{'phi_T':>6s} {'parts':>5s}  description")
    for name in objects.names():
        i = objects.object_info(name)
        print(f"{name:22s} {i.mass_kg * 1e3:7.1f} {i.height_m * 1e3:9.1f} {i.radius_m * 1e3:9.1f} "
              f"{i.volume_m3 * 1e6:8.2f} {i.phi_t:6.3f} {i.n_parts:5d}  "
              f"{objects.description(name)}")
    return 0


def _show(args: argparse.Namespace) -> int:
    from entangle_bench.objects.plot import plot_object

    params = _params(args.name, args.set)
    info = objects.object_info(args.name, params)
    print(f"{info.name}: {objects.description(args.name)}")
    print(f"  mass            {info.mass_kg * 1e3:.2f} g")
    print(f"  height          {info.height_m * 1e3:.2f} mm")
    print(f"  radius          {info.radius_m * 1e3:.2f} mm (largest distance from vertical axis)")
    print(f"  volume          {info.volume_m3 * 1e6:.3f} cm^3")
    print(f"  hull volume     {info.hull_volume_m3 * 1e6:.3f} cm^3")
    print(f"  phi_T           {info.phi_t:.4f} (volume / convex-hull volume)")
    print(f"  parts           {info.n_parts}")
    print(f"  centre of mass  {', '.join(f'{c * 1e3:.2f}' for c in info.center_of_mass_m)} mm")
    for key, value in info.dims.items():
        print(f"  {key:15s} {value:g}")
    for note in info.notes:
        print(f"  note: {note}")
    out = Path(args.out or os.path.join("results", "scratch", "objects", f"{args.name}.png"))
    print(f"  picture         {plot_object(args.name, params, out)}")
    return 0


def _decompose(args: argparse.Namespace) -> int:
    try:
        params = _params(args.target, args.set)
        label = args.target
    except UnknownNameError:
        if not (os.sep in args.target or Path(args.target).suffix):
            raise
        params = apply_overrides(meshes.MeshObjectParams(str(Path(args.target).resolve())),
                                 args.set)
        label = Path(args.target).stem
    if not isinstance(params, meshes.MeshObjectParams):
        print(f"{args.target} is built from primitives: no decomposition needed")
        return 0
    if args.scale is not None:
        params = dataclasses.replace(params, scale=args.scale)
    if args.cache_dir is not None:
        params = dataclasses.replace(params, cache_dir=args.cache_dir)
    mesh, notes = meshes.load_mesh(params.path, params.scale)
    for note in notes:
        print(f"repair: {note}")
    result = meshes.decompose_object(params, mesh, progress=True, force=args.force)
    parts = [ConvexMesh(f"part{i:02d}", v) for i, (v, _) in enumerate(result.parts)]
    union = union_moments(parts, solid=True, samples_per_part=5000).volume
    source = "cache hit" if result.from_cache else "computed"
    print(f"{label}: {len(parts)} convex parts ({source}; CoACD took {result.seconds:.1f} s)")
    print(f"  mesh volume {mesh.volume * 1e6:.3f} cm^3, union of parts {union * 1e6:.3f} cm^3 "
          f"({union / mesh.volume:.3f} of the mesh)")
    print(f"  cache file {result.path}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run the chosen `objects` action; return the exit code."""
    if args.action == "list":
        return _list()
    if args.action == "show":
        return _show(args)
    return _decompose(args)
