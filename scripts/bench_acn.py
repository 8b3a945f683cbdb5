"""Time the ACN and local-field metrics on a 12-filament x 100-segment tangle and print a table.

Usage: python scripts/bench_acn.py [--repeats N]
Not a test: timings depend on the machine and its load; the target is < 50 ms for the full ACN
matrix (pairwise + self terms) and a few seconds for local fields sampled at every vertex.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np

from entangle_bench.metrics.acn import acn_matrix, segment_pair_solid_angle
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.metrics.synthetic import helix_tangle


def timings(func: Callable[[], object], repeats: int) -> tuple[float, float]:
    """Best and median wall time of `repeats` calls, in ms."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return 1e3 * min(times), 1e3 * float(np.median(times))


def all_pairs_by_klenin_langowski(curves: np.ndarray) -> float:
    """Total ACN summing the four-arcsin formula over explicit segment pairs (reference path)."""
    k, m = curves.shape[:2]
    starts = curves[:, :-1].reshape(-1, 3)
    ends = curves[:, 1:].reshape(-1, 3)
    curve = np.repeat(np.arange(k), m - 1)
    i, j = np.triu_indices(len(starts), 1)
    keep = (curve[i] != curve[j]) | (j - i > 1)
    i, j = i[keep], j[keep]
    total = 0.0
    for p0 in range(0, len(i), 1 << 17):
        a, b = i[p0 : p0 + (1 << 17)], j[p0 : p0 + (1 << 17)]
        total += segment_pair_solid_angle(
            starts[a], ends[a], starts[b], ends[b], signed=False
        ).sum()
    return total / (2 * np.pi)


def main() -> None:
    """Run the benchmark and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20, help="calls per timing (default 20)")
    args = parser.parse_args()
    curves = helix_tangle(12, 101)
    n_seg = 12 * 100
    pairs = n_seg * (n_seg - 1) // 2 - 12 * 99
    rows = [
        ("acn_matrix (grid kernel, pairwise + self)", pairs, lambda: acn_matrix(curves), 1),
        (
            "same pairs, Klenin-Langowski per pair",
            pairs,
            lambda: all_pairs_by_klenin_langowski(curves),
            4,
        ),
        ("local_fields, 20 mm, every vertex", 12 * 101, lambda: local_fields(curves), 4),
        (
            "local_fields, 20 mm, every 5 mm",
            None,
            lambda: local_fields(curves, spacing_m=0.005),
            4,
        ),
    ]
    total = float(acn_matrix(curves)[np.triu_indices(12)].sum())
    reference = all_pairs_by_klenin_langowski(curves)
    fields = local_fields(curves)
    print("tangle: 12 helical filaments x 100 segments (entangle_bench.metrics.synthetic)")
    print(f"total ACN {total:.6f} (Klenin-Langowski pair sum {reference:.6f})")
    print(
        f"local fields: mean ACN {fields.mean_acn:.3f}, max {fields.max_acn:.3f}; "
        f"mean count {fields.mean_count:.2f}, max {fields.max_count}"
    )
    print(f"{'case':44s} {'pairs/samples':>13s} {'best ms':>9s} {'median ms':>10s}")
    for name, size, func, divisor in rows:
        best, median = timings(func, max(1, args.repeats // divisor))
        size_text = "" if size is None else f"{size:d}"
        print(f"{name:44s} {size_text:>13s} {best:9.1f} {median:10.1f}")


if __name__ == "__main__":
    main()
