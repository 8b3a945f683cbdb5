"""Synthetic tangles of intertwined helices, for benchmarks, demos and plots (no simulation)."""

from __future__ import annotations

import numpy as np

from entangle_bench.config import check_range


def helix_tangle(
    n_filaments: int = 12,
    n_points: int = 101,
    *,
    height_m: float = 0.12,
    radius_m: float = 0.02,
    turns: float = 2.5,
    noise_m: float = 0.003,
    seed: int = 0,
) -> np.ndarray:
    """(K, M, 3) polylines (m): helices about the z axis with alternating handedness and noise.

    Filament k starts at angle 2 pi k / K at height `height_m`, descends to z = 0 while winding
    `turns` times (even k counter-clockwise, odd k clockwise) at a radius varying around
    `radius_m`, plus smooth random offsets of size `noise_m`; opposite-handed helices cross.
    """
    check_range("n_filaments", n_filaments, 1, None)
    check_range("n_points", n_points, 2, None)
    check_range("height_m", height_m, 0.0, None, low_open=True)
    check_range("radius_m", radius_m, 0.0, None, low_open=True)
    check_range("turns", turns, 0.0, None)
    check_range("noise_m", noise_m, 0.0, None)
    rng = np.random.default_rng(seed)
    u = np.linspace(0.0, 1.0, n_points)
    curves = np.empty((n_filaments, n_points, 3))
    for k in range(n_filaments):
        hand = 1.0 if k % 2 == 0 else -1.0
        theta = 2 * np.pi * k / n_filaments + hand * 2 * np.pi * turns * u
        rho = radius_m * (1.0 + 0.3 * np.sin(2 * np.pi * (u + rng.uniform()) * rng.uniform(1, 3)))
        curves[k, :, 0] = rho * np.cos(theta)
        curves[k, :, 1] = rho * np.sin(theta)
        curves[k, :, 2] = height_m * (1.0 - u)
        for axis in range(3):
            phase, freq = rng.uniform(0, 2 * np.pi, 2), rng.uniform(1, 4, 2)
            curves[k, :, axis] += noise_m * np.sin(2 * np.pi * np.outer(u, freq) + phase).sum(1)
    return curves
