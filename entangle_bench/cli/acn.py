"""`entangle-bench acn FILE.npz`: total and pairwise average crossing number of stored curves."""

from __future__ import annotations

import argparse

import numpy as np

from entangle_bench.config import check_range
from entangle_bench.metrics.acn import acn_matrix
from entangle_bench.metrics.curve_file import load_curves
from entangle_bench.metrics.local_fields import local_fields


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Attach the `acn` subcommand."""
    parser = subparsers.add_parser(
        "acn",
        help="average crossing number (ACN) of curves in an .npz file",
        description="Print the total ACN and the pairwise ACN matrix of curves stored as a "
        "(K, M, 3) array under key 'curves', or as one (M, 3) array per key (in stored order).",
    )
    parser.add_argument("file", help=".npz archive with the curves (coordinates in m)")
    parser.add_argument(
        "--local-diameter",
        type=float,
        default=None,
        metavar="D",
        help="also summarize local fields in spheres of diameter D (m, e.g. 0.02) at every vertex",
    )
    parser.set_defaults(run=run)


def format_matrix(matrix: np.ndarray) -> str:
    """Text table of a (K, K) matrix with curve indices as row and column labels."""
    k = len(matrix)
    lines = ["curve " + "".join(f"{j:>9d}" for j in range(k))]
    lines += [f"{i:>5d} " + "".join(f"{v:9.3f}" for v in matrix[i]) for i in range(k)]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Read the curves, print total ACN, the matrix and optionally the local-field summary."""
    if args.local_diameter is not None:
        check_range("--local-diameter (m)", args.local_diameter, 0.0, None, low_open=True)
    data = load_curves(args.file)
    matrix = acn_matrix(data.curves)
    k = len(data.curves)
    self_sum = float(np.trace(matrix))
    pair_sum = float(matrix[np.triu_indices(k, 1)].sum())
    points = [len(c) for c in data.curves]
    span = f"{min(points)}" if min(points) == max(points) else f"{min(points)}-{max(points)}"
    print(f"{data.path}: {k} curve(s), {span} points each")
    if any(name != f"curves[{i}]" for i, name in enumerate(data.names)):
        for i, name in enumerate(data.names):
            print(f"  curve {i}: key {name!r}")
    print(f"total ACN: {pair_sum + self_sum:.4f} (pairs i<j: {pair_sum:.4f}, self: {self_sum:.4f})")
    print("ACN matrix (off-diagonal: pairwise ACN, diagonal: self ACN):")
    print(format_matrix(matrix))
    if args.local_diameter is not None:
        fields = local_fields(data.curves, diameter_m=args.local_diameter)
        print(
            f"local fields, sphere diameter {fields.diameter_m * 1e3:.1f} mm, "
            f"{len(fields.points)} samples (every vertex):"
        )
        print(f"  local ACN:            mean {fields.mean_acn:.4f}  max {fields.max_acn:.4f}")
        print(f"  local filament count: mean {fields.mean_count:.3f}  max {fields.max_count:d}")
    return 0
