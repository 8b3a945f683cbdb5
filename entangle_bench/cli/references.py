"""`entangle-bench references`: recompute the stored PyElastica references of the rod cases."""

from __future__ import annotations

import argparse
from pathlib import Path

from entangle_bench.cli.compare import DEFAULT_CASES
from entangle_bench.errors import ParameterError
from entangle_bench.rods.case import load_case
from entangle_bench.rods.references import (
    CONVERGENCE_ELEMENTS,
    PERTURBATION_RAD,
    REFERENCE_ELEMENTS,
    generate_reference,
    has_reference,
    reference_path,
    stored_elements,
)


def _counts(text: str) -> tuple[int, ...]:
    """Parse 'N1,N2,...' into element counts."""
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected integers N1,N2,..., got {text!r}") from None
    if not values or min(values) < 4:
        raise argparse.ArgumentTypeError(f"element counts must be >= 4, got {text!r}")
    return values


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Attach the `references` subcommand."""
    parser = subparsers.add_parser(
        "references",
        help="recompute the stored PyElastica reference centerlines of rod cases (minutes per case)",
        description="Run PyElastica on rod cases and store each equilibrium centerline with its settings in "
        "<cases folder>/references/<case>_pyelastica_<elements>.npz (written atomically). Without --cases: "
        "every case that already has a stored reference; without --elements: the element counts already "
        f"stored for each case, or {CONVERGENCE_ELEMENTS},{REFERENCE_ELEMENTS} for a case with none.",
    )
    parser.add_argument(
        "--cases", type=Path, nargs="+", default=None,
        help=f"rod case files (default: cases in {DEFAULT_CASES} with a stored reference)",
    )
    parser.add_argument(
        "--elements", type=_counts, default=None, metavar="N1,N2",
        help="PyElastica resolutions (default: those stored, else "
        f"{CONVERGENCE_ELEMENTS},{REFERENCE_ELEMENTS})",
    )
    parser.add_argument(
        "--perturbation", type=float, default=PERTURBATION_RAD,
        help=f"out-of-plane turn of the start shape, rad (default {PERTURBATION_RAD})",
    )
    parser.add_argument("--progress", action="store_true", help="show a progress bar per run")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Recompute and store every requested reference; print one line per run."""
    if args.cases is None:
        cases = [load_case(p) for p in sorted(DEFAULT_CASES.glob("*.json"))]
        cases = [c for c in cases if has_reference(c)]
        if not cases:
            raise ParameterError(f"no case in {DEFAULT_CASES} has a stored reference; name them with --cases")
    else:
        cases = [load_case(p) for p in args.cases]
    for case in cases:
        counts = args.elements or stored_elements(case) or (CONVERGENCE_ELEMENTS, REFERENCE_ELEMENTS)
        for n in counts:
            result = generate_reference(case, n, perturbation=args.perturbation, progress=args.progress)
            print(
                f"{case.name}: {n} elements, {result.settings['sim_time_s']:.3g} s simulated, "
                f"wall {result.wall_time_s:.1f} s -> {reference_path(case, n)}",
                flush=True,
            )
    return 0
