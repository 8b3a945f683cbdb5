"""`entangle-bench describe TASK`: a task's compiled scene: effects, stages, collision pairs."""

from __future__ import annotations

import argparse

from entangle_bench import effects as fx
from entangle_bench import stability
from entangle_bench.presets import DEFAULT_PRESET, PRESETS
from entangle_bench.scene import build_scene
from entangle_bench.suite import TASKS, resolve_config


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Attach the `describe` subcommand."""
    p = sub.add_parser(
        "describe", help="effects, disabled engine stages and collision pairs of a task"
    )
    p.add_argument("task", help="task name (see `entangle-bench tasks`)")
    p.add_argument("--preset", choices=sorted(PRESETS), default=None, help="numerical preset")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="PATH=VALUE",
        help="override a config field, e.g. effects.ground_contact=false (repeatable)",
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Compile the task's scene and print what it contains."""
    task = TASKS.get(args.task).name
    config = resolve_config(task, args.preset, args.overrides)
    scene = build_scene(config.scene_config())
    model = scene.model
    print(f"{task} (preset {args.preset or DEFAULT_PRESET})")
    print("effects:")
    for name, value in config.effects.summary().items():
        if isinstance(value, bool):
            value = "on" if value else "off"
        print(f"  {name:28s} {value}")
    fil = config.gripper.filament
    l_g = fx.gravity_length_m(fil, config.effects)
    weight = fx.submerged_weight_fraction(fil, config.effects)
    print(
        f"  {'length / gravity length':28s} l/l_g = {fil.length_m / l_g:.3g} "
        f"(l_g = {l_g * 1e3:.3g} mm; net weight {weight:+.2f} of the dry weight"
        f"{', floats' if weight < 0 else ''})"
    )
    print(f"disabled engine stages: {', '.join(fx.disabled_stages(model)) or 'none'}")
    print(
        f"model: nbody={model.nbody} nv={model.nv} ngeom={model.ngeom} "
        f"nexclude={model.nexclude} npair={model.npair}"
    )
    pairs = fx.collision_pairs(model)
    silent = [
        model.geom(g).name
        for g in range(model.ngeom)
        if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0
    ]
    print(f"collision pairs: {len(pairs)}")
    for kind, count in fx.pair_kinds(model, pairs).items():
        print(f"  {kind:28s} {count}")
    print(
        f"geoms that never collide: {len(silent)}"
        + (f" ({', '.join(silent[:4])}{', ...' if len(silent) > 4 else ''})" if silent else "")
    )
    warnings = stability.envelope_warnings(config)
    largest = stability.stable_timestep_s(config)
    print(
        f"stability envelope: {'inside' if not warnings else f'{len(warnings)} warning(s)'} "
        f"(timestep {config.numerics.timestep_s * 1e3:g} ms; largest stable measured: "
        + (f"{largest * 1e3:.3g} ms)" if largest is not None else "outside the map)")
    )
    for text in warnings:
        print(f"  warning: {text}")
    return 0
