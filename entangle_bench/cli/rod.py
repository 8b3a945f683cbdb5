"""`entangle-bench rod CASE.json --out OUT.npz`: one rod case brought to static equilibrium."""

from __future__ import annotations

import argparse
from pathlib import Path

from entangle_bench.presets import DEFAULT_PRESET, PRESETS
from entangle_bench.rods.case import case_path, load_case
from entangle_bench.rods.elastica_engine import solve_elastica
from entangle_bench.rods.representations import DEFAULT_REPRESENTATION, REPRESENTATIONS, solve_representation

#: PyElastica elements when --segments is not given.
DEFAULT_ELEMENTS = 50


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Attach the `rod` subcommand."""
    parser = subparsers.add_parser(
        "rod",
        help="static equilibrium of one rod case (JSON) with MuJoCo or PyElastica",
        description="Bring the clamped rod of CASE.json to static equilibrium and write its centerline "
        "(M, 3) at uniform arclength from base to tip, the wall time and the settings to OUT.npz.",
    )
    parser.add_argument("case", help="packaged rod case by name (soft_cantilever, ...; see `entangle-bench tasks`) "
                                     "or a rod-case file (JSON, SI units), relative to the current folder")
    parser.add_argument("--out", type=Path, required=True, help="result file (.npz)")
    parser.add_argument("--engine", choices=("mujoco", "pyelastica"), default="mujoco")
    parser.add_argument(
        "--preset", choices=sorted(PRESETS), default=DEFAULT_PRESET,
        help=f"numerical preset of the MuJoCo filament (default {DEFAULT_PRESET})",
    )
    parser.add_argument(
        "--segments", type=int, default=None,
        help=f"MuJoCo segments (default: the preset's) or PyElastica elements (default {DEFAULT_ELEMENTS})",
    )
    parser.add_argument(
        "--representation", choices=REPRESENTATIONS, default=DEFAULT_REPRESENTATION,
        help="MuJoCo filament representation (default ball: the harness filament)",
    )
    parser.add_argument("--points", type=int, default=201, help="centerline points (default 201)")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Solve the case, write the result and print a one-line summary."""
    case = load_case(case_path(args.case))
    if args.engine == "pyelastica":
        result = solve_elastica(case, args.segments or DEFAULT_ELEMENTS, n_output=args.points)
    else:
        result = solve_representation(
            case, args.representation, args.segments, preset=args.preset, points=args.points
        )
    result.save_npz(args.out)
    tip = ", ".join(f"{v:.5f}" for v in result.centerline[-1])
    resolution = result.settings.get("n_segments", result.settings.get("n_elements"))
    print(
        f"{case.name}: {result.engine} ({resolution} segments) tip ({tip}) m, "
        f"wall {result.wall_time_s:.2f} s -> {args.out}"
    )
    return 0
