"""Accuracy-time study (`entangle_bench.studies.accuracy_time`): rod statics and dynamics, trials, Pareto plot.

Usage: python scripts/accuracy_time_study.py [--smoke] [--out DIR] [--seeds N] [--elements N] [--skip-trial]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from entangle_bench.studies import accuracy_time


def main(argv: list[str] | None = None) -> int:
    """Run the study, write the tables and the plot, print the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="a few seconds of everything (CI)")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default results/accuracy_time)")
    parser.add_argument("--seeds", type=int, default=None, help="trial seeds (default 3; smoke 1)")
    parser.add_argument("--elements", type=int, default=50, help="PyElastica reference elements")
    parser.add_argument("--skip-trial", action="store_true", help="rod parts only")
    args = parser.parse_args(argv)
    out = args.out or accuracy_time.ROOT / "results" / "accuracy_time"
    print(accuracy_time.run_study(out, args.smoke, args.seeds, args.elements, args.skip_trial))
    return 0


if __name__ == "__main__":
    sys.exit(main())
