"""`entangle-bench compare`: every rod case on MuJoCo and PyElastica against its reference.

The reference is the closed-form or boundary-value solution, or for cases with stored PyElastica references
(`tasks/rod_cases/references/`) the stored 200-element run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd
from tqdm import tqdm

from entangle_bench import resources
from entangle_bench.errors import ParameterError
from entangle_bench.presets import DEFAULT_PRESET, PRESETS
from entangle_bench.results import atomic_write_csv
from entangle_bench.rods.case import load_case
from entangle_bench.rods.comparison import compare_case
from entangle_bench.rods.representations import DEFAULT_REPRESENTATION, REPRESENTATIONS

DEFAULT_CASES = resources.rod_cases_dir()

#: Columns printed (the CSV holds all of them).
SHOWN = {
    "case": "case",
    "reference": "reference",
    "mujoco_segments": "mj n",
    "mujoco_vs_reference_max": "mj-ref max/L",
    "mujoco_vs_reference_rms": "mj-ref rms/L",
    "mujoco_vs_pyelastica_max": "mj-pe max/L",
    "mujoco_vs_analytic_max": "mj-an max/L",
    "pyelastica_vs_analytic_max": "pe-an max/L",
    "pyelastica_coarse_vs_fine_max": "pe coarse-fine max/L",
    "pyelastica_observed_order": "pe order",
    "mujoco_wall_s": "mj wall s",
    "pyelastica_wall_s": "pe wall s",
}


def _elements(text: str) -> tuple[int, int]:
    """Parse 'N1,N2' into two element counts."""
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two integers N1,N2, got {text!r}") from None
    if len(values) != 2:
        raise argparse.ArgumentTypeError(f"expected two integers N1,N2, got {text!r}")
    return values[0], values[1]


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Attach the `compare` subcommand."""
    parser = subparsers.add_parser(
        "compare",
        help="run every rod case on MuJoCo and PyElastica and compare with the analytic reference",
        description="For each rod case: max and RMS centerline distance / L of MuJoCo against "
        "PyElastica (finer resolution) and against the case's reference (closed form, boundary-value "
        "solution, or the stored 200-element PyElastica run), PyElastica's own error at two resolutions, "
        "and the wall times. Writes compare.csv to --out.",
    )
    parser.add_argument("--cases", type=Path, default=DEFAULT_CASES, help="folder of rod cases (*.json)")
    parser.add_argument("--preset", choices=sorted(PRESETS), default=DEFAULT_PRESET)
    parser.add_argument("--segments", type=int, default=None, help="MuJoCo segments (default: preset)")
    parser.add_argument("--representation", choices=REPRESENTATIONS, default=DEFAULT_REPRESENTATION)
    parser.add_argument(
        "--elements", type=_elements, default=(50, 100), metavar="N1,N2",
        help="PyElastica resolutions for cases without stored references (default 50,100)",
    )
    parser.add_argument(
        "--rerun-pyelastica", action="store_true",
        help="run PyElastica at --elements also on cases with stored references (minutes per case)",
    )
    parser.add_argument("--out", type=Path, default=Path("results") / "compare", help="output folder")
    parser.add_argument(
        "--cache", type=Path, default=None,
        help="folder to keep analytic and PyElastica solutions in, keyed by case content (default: none)",
    )
    parser.add_argument("--no-progress", action="store_true")
    parser.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Compare every case, print the table and write compare.csv atomically."""
    paths = sorted(Path(args.cases).glob("*.json"))
    if not paths:
        raise ParameterError(f"--cases {args.cases}: no rod case files (*.json) found")
    cases = [load_case(p) for p in paths]
    rows = []
    for case in tqdm(cases, desc="compare", unit="case", file=sys.stderr, disable=args.no_progress):
        rows.append(
            compare_case(
                case, args.preset, args.elements, args.representation, args.segments,
                cache_dir=args.cache, stored=not args.rerun_pyelastica,
            )
        )
    frame = pd.DataFrame(rows)
    out = Path(args.out) / "compare.csv"
    atomic_write_csv(frame, out)
    shown = frame[list(SHOWN)].rename(columns=SHOWN)
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(shown.to_string(index=False, float_format=lambda v: f"{v:.2e}"))
    for row in rows:
        if row["note"]:
            print(f"note: {row['case']}: {row['note']}")
    print(f"table: {out}")
    return 0
