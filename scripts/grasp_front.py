"""Numerical variants of one gripper judged on grasp outcomes against a fine run (issue 11, item 4).

Each `--variant LABEL=FOLDER` is a results folder (or trials file) of the same gripper run with other numerics;
`--fine LABEL=FOLDER` is the reference. Rows of `--task` at `--offset` are compared: success with Wilson 95 %
intervals, unstable trials, cost, outcomes on shared seeds and a verdict (`entangle_bench.studies.grasp_front`).
`--pullout LABEL=FOLDER` (repeatable, the fine label among them) adds pull-out toughness per object. Writes
OUT/front.csv, OUT/toughness.csv, OUT/front.md and OUT/front.png, and prints the tables.

Usage: python scripts/grasp_front.py --fine fine=DIR --variant candidate=DIR [--variant ...]
           [--pullout LABEL=DIR ...] [--task top_drape/eight_branch_tree] [--offset 0] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from entangle_bench import calibration
from entangle_bench.atomic import atomic_write_text
from entangle_bench.errors import EntangleBenchError, ParameterError
from entangle_bench.results import atomic_write_csv, markdown, read_results
from entangle_bench.studies import grasp_front


def _labelled(text: str) -> tuple[str, Path]:
    label, sep, folder = text.partition("=")
    if not label or not sep or not folder:
        raise ParameterError(f"{text!r}: expected LABEL=FOLDER, e.g. fine=results/calibration/fine_0125ms")
    return label, Path(folder)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fine", required=True, metavar="LABEL=FOLDER", help="the fine reference run")
    parser.add_argument("--variant", action="append", default=[], metavar="LABEL=FOLDER", help="repeatable")
    parser.add_argument("--pullout", action="append", default=[], metavar="LABEL=FOLDER",
                        help="pull-out rows per variant (repeatable; include the fine run's label)")
    parser.add_argument("--task", default="top_drape/eight_branch_tree")
    parser.add_argument("--offset", type=float, default=0.0, help="centering offset of the condition, m")
    parser.add_argument("--out", type=Path, default=Path("results/calibration/grasp_front"))
    args = parser.parse_args()
    try:
        fine, fine_folder = _labelled(args.fine)
        folders = dict([(fine, fine_folder), *map(_labelled, args.variant)])
        variants = {label: calibration.condition_rows(read_results(folder), args.task, args.offset)
                    for label, folder in folders.items()}
        empty = [label for label, rows in variants.items() if rows.empty]
        if empty:
            raise ParameterError(f"no rows of {args.task} at offset {args.offset:g} m in: {', '.join(empty)}")
        front = grasp_front.front_table(variants, fine)
        pullouts = {label: read_results(folder) for label, folder in map(_labelled, args.pullout)}
        toughness = grasp_front.toughness_front(pullouts, fine) if pullouts else None
    except EntangleBenchError as exc:
        print(f"grasp_front: error: {exc}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_csv(front, args.out / "front.csv")
    text = [f"# Numerical variants on grasp outcomes: {args.task} at offset {args.offset:g} m", "",
            markdown(front, digits=3), ""]
    if toughness is not None:
        atomic_write_csv(toughness, args.out / "toughness.csv")
        text += ["## Pull-out toughness", "", markdown(toughness, digits=3), ""]
    default = grasp_front.cheapest_agreeing(front, toughness)
    if default is None:
        default = f"open (the fine run has fewer than {calibration.MIN_TRIALS} scored trials)"
    text.append(f"Cheapest variant that agrees with the fine run: {default}")
    grasp_front.plot_front(front, args.out / "front.png", f"{args.task}, offset {args.offset:g} m")
    atomic_write_text(args.out / "front.md", "\n".join(text) + "\n")
    print("\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
