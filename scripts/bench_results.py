"""Benchmark: CSV against Parquet for a synthetic sweep table shaped like trial rows (typed columns).

Builds N rows (default 10^5) with the kinds of columns a trial row has (ids and labels, seeds, outcomes,
metrics, contact counts, a flattened configuration, versions), writes both files as the runner does
(`atomic_write_csv`, `write_parquet`), reads them back with `read_results` and prints sizes and times.
Usage: python scripts/bench_results.py [--rows 100000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from entangle_bench.results import (
    CSV_NAME,
    FAILURE,
    PARQUET_NAME,
    SUCCESS,
    UNSTABLE,
    atomic_write_csv,
    read_results,
    typed,
    write_parquet,
)


def synthetic_rows(n: int, seed: int = 0) -> pd.DataFrame:
    """N trial-like rows: 8 text, 2 int, 1 bool, 40 float, 12 count and 50 configuration columns."""
    rng = np.random.default_rng(seed)
    outcome = rng.choice([SUCCESS, FAILURE, UNSTABLE], n, p=[0.3, 0.65, 0.05])
    columns: dict[str, object] = {
        "trial_id": [f"{v:016x}" for v in rng.integers(0, 2**63, n)],
        "task": "top_drape/eight_branch_tree",
        "condition": [f"eight_branch_tree offset_m={v:.3f}" for v in rng.choice([0.0, 0.01, 0.02], n)],
        "preset": "balanced",
        "seed": np.arange(n),
        "success": outcome == SUCCESS,
        "outcome": outcome,
        "failure_mode": np.where(outcome == FAILURE, "never_lifted", ""),
        "unstable_reason": np.where(outcome == UNSTABLE, "speed>20m/s", ""),
        "version.mujoco": "3.17.0",
        "version.entangle_bench": "0.1.0",
        "sim_time_s": rng.uniform(2, 8, n),
    }
    columns.update({f"metric_{k}": rng.normal(size=n) for k in range(40)})
    columns.update({f"contacts_{k}": rng.integers(0, 200, n) for k in range(12)})
    columns.update({f"config.field_{k}": np.full(n, 0.001 * k) for k in range(45)})
    columns.update({f"config.text_{k}": "radial" for k in range(5)})
    return pd.DataFrame(columns)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=100_000)
    args = parser.parse_args()
    frame = typed(synthetic_rows(args.rows))
    print(f"{args.rows} rows x {frame.shape[1]} columns")
    print("| file | size (MB) | write (s) | read, typed (s) |")
    print("|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        for name, write in ((CSV_NAME, atomic_write_csv), (PARQUET_NAME, write_parquet)):
            path = Path(folder) / name
            start = time.perf_counter()
            write(frame, path)
            written = time.perf_counter() - start
            start = time.perf_counter()
            back = read_results(path)
            seconds = time.perf_counter() - start
            pd.testing.assert_frame_equal(back, frame)
            print(f"| {name} | {path.stat().st_size / 1e6:.1f} | {written:.2f} | {seconds:.2f} |")


if __name__ == "__main__":
    main()
