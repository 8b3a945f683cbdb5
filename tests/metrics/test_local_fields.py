"""Tests of local ACN / filament-count fields against analytic values and dense resampling."""

from __future__ import annotations

import numpy as np
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.metrics.acn import acn_total
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.metrics.synthetic import helix_tangle


def clipped_by_dense_resampling(
    curves: np.ndarray, center: np.ndarray, radius: float, per_segment: int = 100
) -> list[np.ndarray]:
    """Pieces of the curves inside a sphere, found by keeping dense sub-points that lie inside."""
    pieces = []
    u = np.linspace(0.0, 1.0, per_segment, endpoint=False)
    for curve in curves:
        dense = np.concatenate(
            [curve[:-1, None, :] + u[None, :, None] * np.diff(curve, axis=0)[:, None, :]]
        ).reshape(-1, 3)
        dense = np.vstack([dense, curve[-1]])
        inside = np.linalg.norm(dense - center, axis=1) <= radius
        edges = np.flatnonzero(np.diff(np.r_[0, inside.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2]):
            if stop - start >= 2:
                pieces.append(dense[start:stop])
    return pieces


def test_perpendicular_lines_match_rectangle_solid_angle():
    # Sample at the origin on line a (x axis); line b is y-parallel at height d. Inside the sphere
    # of radius R the pieces are [-R, R] and a chord of half length sqrt(R^2 - d^2).
    radius, d = 0.01, 0.002
    x = np.linspace(-0.05, 0.05, 11)
    a = np.column_stack([x, 0 * x, 0 * x])
    b = np.column_stack([0 * x, x + 0.0013, 0 * x + d])
    fields = local_fields([a, b], diameter_m=2 * radius)
    at_origin = np.flatnonzero(np.all(fields.points == 0.0, axis=1))
    assert len(at_origin) == 1
    half_a, half_b = radius, np.sqrt(radius**2 - d**2)
    omega = 4 * np.arcsin(half_a * half_b / np.sqrt((half_a**2 + d**2) * (half_b**2 + d**2)))
    assert fields.local_acn[at_origin[0]] == pytest.approx(omega / (2 * np.pi), rel=1e-9)
    assert fields.local_count[at_origin[0]] == 2
    # Samples at |x| >= 0.02 have only their own straight line nearby.
    far = np.abs(fields.points[:, 0]) >= 0.02
    assert np.all(fields.local_count[far & (fields.curve_index == 0)] == 1)
    assert np.all(fields.local_acn[far & (fields.curve_index == 0)] == 0.0)


def test_local_acn_matches_dense_resampling_of_the_sphere():
    curves = helix_tangle(6, 41, seed=2)
    fields = local_fields(curves, diameter_m=0.03)
    rng = np.random.default_rng(0)
    for sample in rng.choice(len(fields.points), size=6, replace=False):
        center = fields.points[sample]
        pieces = clipped_by_dense_resampling(curves, center, 0.015)
        expected = acn_total(pieces)
        # The resampled pieces are slightly shorter, and a sub-segment never subtends a larger
        # solid angle, so the exact clipping can only be larger (by about 1 % here).
        assert expected <= fields.local_acn[sample] + 1e-12
        assert fields.local_acn[sample] == pytest.approx(expected, rel=2e-2, abs=1e-3)


def test_far_filament_leaves_other_fields_unchanged_and_counts_are_bounded():
    curves = helix_tangle(5, 61, seed=1)
    base = local_fields(curves)
    far = curves[0] + [10.0, 0.0, 0.0]
    with_far = local_fields(np.concatenate([curves, far[None]]))
    n = len(base.points)
    np.testing.assert_array_equal(with_far.local_count[:n], base.local_count)
    np.testing.assert_allclose(with_far.local_acn[:n], base.local_acn, rtol=1e-12, atol=1e-15)
    assert np.all(with_far.local_count[n:] == 1)
    alone = local_fields(curves[:1])
    np.testing.assert_allclose(with_far.local_acn[n:], alone.local_acn, rtol=1e-9, atol=1e-15)
    assert np.issubdtype(base.local_count.dtype, np.integer)
    assert base.local_count.min() >= 1 and base.local_count.max() <= 5
    assert base.max_count > 1  # the helices do meet
    summary = base.summary()
    assert summary["mean_local_acn"] == pytest.approx(base.local_acn.mean())
    assert summary["max_local_count"] == base.local_count.max()


def test_spacing_samples_lie_on_the_curves():
    line = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.1, 0.05, 0]])
    fields = local_fields([line], diameter_m=0.01, spacing_m=0.01)
    assert len(fields.points) == 16  # arc length 0.15 m: samples at 0, 0.01, ..., 0.15
    on_x = fields.points[:, 1] == 0.0
    on_corner_leg = np.isclose(fields.points[:, 0], 0.1)
    assert np.all(on_x | on_corner_leg)
    assert np.all(fields.local_count == 1)


def test_rejects_bad_parameters():
    line = np.array([[0.0, 0, 0], [0.1, 0, 0]])
    with pytest.raises(ParameterError, match="diameter_m"):
        local_fields([line], diameter_m=0.0)
    with pytest.raises(ParameterError, match="spacing_m"):
        local_fields([line], spacing_m=-1.0)
