"""Tests of the exact ACN against quadrature, analytic solid angles and Monte Carlo projections."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import dblquad

from entangle_bench.errors import ParameterError
from entangle_bench.metrics.acn import (
    acn_matrix,
    acn_pair,
    acn_self,
    acn_total,
    clean_curves,
    segment_pair_abs_solid_angle,
    segment_pair_solid_angle,
)


def projected_crossings(curves: list[np.ndarray], directions: np.ndarray) -> np.ndarray:
    """Number of crossings in the 2D projection along each direction (independent of the ACN code).

    Counts every pair of segments whose projections properly intersect, skipping pairs of
    neighbouring segments of one curve (they share a vertex).
    """
    starts = np.concatenate([c[:-1] for c in curves])
    ends = np.concatenate([c[1:] for c in curves])
    curve_id = np.concatenate([np.full(len(c) - 1, k) for k, c in enumerate(curves)])
    seg_id = np.concatenate([np.arange(len(c) - 1) for c in curves])
    i, j = np.triu_indices(len(starts), 1)
    keep = (curve_id[i] != curve_id[j]) | (np.abs(seg_id[i] - seg_id[j]) > 1)
    i, j = i[keep], j[keep]
    counts = np.zeros(len(directions), dtype=np.int64)
    for d0 in range(0, len(directions), 64):
        u = directions[d0 : d0 + 64]
        helper = np.where(np.abs(u[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        e1 = np.cross(u, helper)
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        e2 = np.cross(u, e1)
        basis = np.stack([e1, e2], axis=2)  # (n, 3, 2)
        a = np.einsum("si,nij->nsj", starts, basis)
        b = np.einsum("si,nij->nsj", ends, basis)

        def orient(p, q, r):
            return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
                r[..., 0] - p[..., 0]
            )

        ai, bi, aj, bj = a[:, i], b[:, i], a[:, j], b[:, j]
        cross = (orient(ai, bi, aj) * orient(ai, bi, bj) < 0) & (
            orient(aj, bj, ai) * orient(aj, bj, bi) < 0
        )
        counts[d0 : d0 + 64] = cross.sum(axis=1)
    return counts


def uniform_directions(n: int, rng: np.random.Generator) -> np.ndarray:
    """Unit vectors uniform on the sphere."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def assert_within_mc_error(exact: float, counts: np.ndarray) -> None:
    """Closed form agrees with the Monte Carlo mean within 4 standard errors."""
    mean = counts.mean()
    se = counts.std(ddof=1) / np.sqrt(len(counts))
    assert se > 0
    assert abs(exact - mean) < 4 * se, (exact, mean, se)


def circle(n: int, center, axis_a, axis_b) -> np.ndarray:
    """Closed polygon with n sides inscribed in the unit circle spanned by two axes."""
    theta = np.linspace(0.0, 2 * np.pi, n + 1)
    pts = (
        np.asarray(center, float)
        + np.outer(np.cos(theta), axis_a)
        + np.outer(np.sin(theta), axis_b)
    )
    pts[-1] = pts[0]
    return pts


def test_segment_pair_equals_gauss_integral_by_quadrature():
    rng = np.random.default_rng(3)
    for _ in range(2):
        p1, p2, p3, p4 = rng.normal(size=(4, 3))
        s, t = p2 - p1, p4 - p3

        def integrand(v, u, p1=p1, p3=p3, s=s, t=t):
            d = (p1 + u * s) - (p3 + v * t)
            return np.dot(np.cross(s, t), d) / np.linalg.norm(d) ** 3

        quad, _ = dblquad(integrand, 0, 1, 0, 1, epsabs=1e-11, epsrel=1e-10)
        assert segment_pair_solid_angle(p1, p2, p3, p4) == pytest.approx(quad, rel=1e-8)
        pair = acn_pair(np.array([p1, p2]), np.array([p3, p4]))
        assert pair == pytest.approx(abs(quad) / (2 * np.pi), rel=1e-8)


def test_perpendicular_segments_match_rectangle_solid_angle_and_tend_to_one():
    # Segments [-L, L] on the x axis and on a y-parallel line at height d: the pair's solid angle is
    # that of a 2L x 2L square seen from distance d, 4 asin(L^2 / (L^2 + d^2)).
    d = 1e-3
    values = []
    for half_length in [1e-3, 1e-2, 1e-1, 1.0]:
        a = np.array([[-half_length, 0, 0], [half_length, 0, 0]])
        b = np.array([[0, -half_length, d], [0, half_length, d]])
        value = acn_pair(a, b)
        exact = 2 / np.pi * np.arcsin(half_length**2 / (half_length**2 + d**2))
        assert value == pytest.approx(exact, rel=1e-10, abs=1e-12)
        values.append(value)
    assert values[0] == pytest.approx(1 / 3, rel=1e-10)
    assert np.all(np.diff(values) > 0)
    # L / d = 1000: 1 - ACN = (2/pi)(pi/2 - asin(1 - 1e-6)) ~ 9e-4.
    assert 1 - values[-1] == pytest.approx(9.0e-4, rel=0.01)


def test_parallel_and_far_segments_give_zero():
    a = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    assert acn_pair(a, a + [0.0, 0.5, 0.0]) < 1e-12  # parallel, coplanar
    assert acn_pair(a, a + [0.3, 0.5, 0.7]) < 1e-12  # parallel, offset out of plane
    b = np.array([[0.0, -0.5, 0.0], [0.0, 0.5, 0.0]])
    far = acn_pair(a, b + [0.0, 0.0, 1e3])
    # Far field: Omega ~ area / distance^2 = 1e-6 sr.
    assert 0 < far < 1e-6


def test_random_polylines_match_monte_carlo_projection_crossings():
    rng = np.random.default_rng(11)
    curves = [np.cumsum(rng.normal(size=(7, 3)), axis=0) for _ in range(3)]
    counts = projected_crossings(curves, uniform_directions(6000, rng))
    assert_within_mc_error(acn_total(curves), counts)
    pair_counts = projected_crossings(curves[:1], uniform_directions(6000, rng))
    assert_within_mc_error(acn_self(curves[0]), pair_counts)


def test_hopf_link_matches_monte_carlo_and_exceeds_two():
    # Two unit circles, each through the other's centre, as 64-gons.
    a = circle(64, [0, 0, 0], [1, 0, 0], [0, 1, 0])
    b = circle(64, [1, 0, 0], [1, 0, 0], [0, 0, 1])
    exact = acn_pair(a, b)
    finer = acn_pair(
        circle(256, [0, 0, 0], [1, 0, 0], [0, 1, 0]), circle(256, [1, 0, 0], [1, 0, 0], [0, 0, 1])
    )
    assert exact == pytest.approx(finer, abs=1e-3)  # converged discretisation (about 2.378)
    rng = np.random.default_rng(5)
    counts = projected_crossings([a, b], uniform_directions(800, rng))
    assert counts.min() >= 2  # every projection of a Hopf link has at least 2 crossings
    assert_within_mc_error(exact, counts)
    assert exact > 2.0
    # Planar circles have no self crossings; also checks the closed curves' shared vertex.
    assert acn_self(a) < 1e-12
    assert acn_total([a, b]) == pytest.approx(exact, abs=1e-12)


def test_grid_kernel_agrees_with_klenin_langowski_pairs():
    rng = np.random.default_rng(2)
    curves = [np.cumsum(rng.normal(size=(n, 3)), axis=0) for n in (9, 14, 5)]
    matrix = acn_matrix(curves)
    for x, a in enumerate(curves):
        for y, b in enumerate(curves):
            i, j = np.meshgrid(np.arange(len(a) - 1), np.arange(len(b) - 1), indexing="ij")
            if x == y:
                keep = j >= i + 2
                i, j = i[keep], j[keep]
            omega = segment_pair_solid_angle(a[i], a[i + 1], b[j], b[j + 1], signed=False)
            assert matrix[x, y] == pytest.approx(omega.sum() / (2 * np.pi), rel=1e-10)


def test_triangle_pair_kernel_agrees_with_klenin_langowski():
    rng = np.random.default_rng(9)
    p1, p2, p3, p4 = rng.normal(size=(4, 2000, 3))
    fast = segment_pair_abs_solid_angle(p1, p2, p3, p4)
    reference = segment_pair_solid_angle(p1, p2, p3, p4, signed=False)
    np.testing.assert_allclose(fast, reference, rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(np.abs(segment_pair_solid_angle(p1, p2, p3, p4)), reference)
    assert np.all(segment_pair_abs_solid_angle(p1, p2, p2, p4) == 0.0)  # shared end point


def test_matrix_consistent_with_pair_self_and_total():
    rng = np.random.default_rng(4)
    curves = rng.normal(size=(4, 12, 3)).cumsum(axis=1)
    matrix = acn_matrix(curves)
    np.testing.assert_array_equal(matrix, matrix.T)
    assert matrix[1, 3] == pytest.approx(acn_pair(curves[1], curves[3]), rel=1e-12)
    assert matrix[2, 2] == pytest.approx(acn_self(curves[2]), rel=1e-12)
    assert acn_total(curves) == pytest.approx(matrix[np.triu_indices(4)].sum(), rel=1e-12)
    assert acn_pair(curves[0], curves[1]) == pytest.approx(
        acn_pair(curves[1][::-1], curves[0]), rel=1e-12
    )


def test_invariant_under_rotation_translation_and_scaling():
    rng = np.random.default_rng(6)
    curves = rng.normal(size=(5, 20, 3)).cumsum(axis=1) * 0.01
    reference = acn_matrix(curves)
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    rotation = q * np.sign(np.diag(r))
    for moved in (
        curves @ rotation.T,
        curves + [3.0, -2.0, 5.0],
        curves * 1e3,
        curves * 1e-3,
        -curves,  # point reflection: ACN is unsigned
    ):
        np.testing.assert_allclose(acn_matrix(moved), reference, rtol=1e-9, atol=1e-12)


def test_blocks_do_not_change_the_result(monkeypatch):
    from entangle_bench.metrics import acn

    rng = np.random.default_rng(8)
    curves = [rng.normal(size=(n, 3)).cumsum(axis=0) for n in (40, 3, 25)]
    reference = acn_matrix(curves)
    for rows, cols in ((5, 7), (7, 3)):
        monkeypatch.setattr(acn, "_ROWS_PER_BLOCK", rows)
        monkeypatch.setattr(acn, "_COLS_PER_BLOCK", cols)
        np.testing.assert_allclose(acn_matrix(curves), reference, rtol=1e-12)
    assert acn_pair(curves[0], curves[2]) == pytest.approx(reference[0, 2], rel=1e-12)


def test_clean_curves_rejects_bad_input_naming_the_curve():
    good = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0]])
    with pytest.raises(ParameterError, match=r"curve 1: NaN or Inf .* 2"):
        clean_curves([good, np.array([[0.0, 0, 0], [1, 0, 0], [np.nan, 0, 0]])])
    with pytest.raises(ParameterError, match="curve 0: needs at least 2 points"):
        clean_curves([good[:1]])
    with pytest.raises(ParameterError, match=r"curve 0: expected shape \(M, 3\)"):
        clean_curves([good[:, :2]])
    with pytest.raises(ParameterError, match="no curves"):
        clean_curves([])
    with pytest.raises(ParameterError, match=r"\(K, M, 3\)"):
        acn_matrix(good)
    repeated = np.array([[0.0, 0, 0], [1, 0, 0], [1, 0, 0], [1, 1, 0]])
    with pytest.raises(ParameterError, match="curve 1: zero-length segment.* 1"):
        clean_curves([good, repeated])
    (cleaned,) = clean_curves([repeated], drop_degenerate=True)
    np.testing.assert_array_equal(cleaned, good)
    with pytest.raises(ParameterError, match="fewer than 2 distinct points"):
        clean_curves([np.zeros((3, 3))], drop_degenerate=True)
