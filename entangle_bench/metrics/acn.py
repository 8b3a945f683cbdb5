"""Average crossing number (ACN) of polylines, computed exactly segment pair by segment pair.

For two curves a, b the ACN is the mean number of crossings between their projections onto a
plane, averaged over projection directions uniform on the sphere. As an integral (unsigned Gauss
integral; Freedman, He & Wang, Ann. Math. 139:1, 1994):

    ACN(a, b) = 1/(2 pi) * int_a int_b |(dr_a x dr_b) . (r_a - r_b)| / |r_a - r_b|^3,

and the self ACN of one curve is the same integral over unordered pairs of its points.

For two straight segments s = p2 - p1 and t = p4 - p3 the triple product
(s x t) . (r_a - r_b) = (s x t) . (p1 - p3) is constant, so the integrand never changes sign and
the double integral is, up to sign, the solid angle Omega subtended at the origin by the
parallelogram {p3 + v t - p1 - u s : u, v in [0, 1]} (Klenin & Langowski, Biopolymers 54:307,
2000). The projections of the two segments cross exactly for the directions +-u inside that solid
angle, so each segment pair contributes exactly |Omega| / (2 pi): 0 for far or parallel segments,
approaching 1 for two long segments crossing at a small distance. The signed Omega / (4 pi) is the
pair's contribution to the Gauss linking integral.

Two equivalent closed forms of |Omega| are used:
- `segment_pair_solid_angle` follows Klenin & Langowski (four arcsin terms, signed); it is the
  readable reference the fast kernels are tested against;
- the kernels behind `acn_pair`, `acn_self`, `acn_matrix` and the local fields split the
  parallelogram into two triangles whose solid angles follow Van Oosterom & Strackee (IEEE Trans.
  Biomed. Eng. 30:125, 1983), tan(Omega_k / 2) = det / den_k, and add the two half angles with
  one arctan instead of four arcsin. The all-pairs kernel also shares vertex-vertex distances
  and dot products between neighbouring pairs on a grid, which makes the 720,000 segment pairs
  of 12 filaments x 100 segments cost about 50 ms.

Pairs of segments sharing a vertex (adjacent segments, a closed curve's first and last segment)
contribute 0: their projections only touch at the shared vertex.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from entangle_bench.errors import ParameterError

# Segment pairs evaluated per kernel call (bounds temporary memory to a few MiB per array).
_ROWS_PER_BLOCK = 32
_COLS_PER_BLOCK = 2048
# Segments shorter than this fraction of the curve's bounding-box diagonal count as zero-length.
_DEGENERATE_REL_TOL = 1e-12

CurvesLike = np.ndarray | Sequence[np.ndarray]


def clean_curves(curves: CurvesLike, *, drop_degenerate: bool = False) -> list[np.ndarray]:
    """Validate polylines (any length unit) and return them as float64 (M_k, 3) arrays.

    `curves` is a (K, M, 3) array or a sequence of (M_k, 3) arrays. A curve is rejected with a
    ParameterError naming its index if it has the wrong shape, NaN/Inf coordinates, fewer than 2
    points, or zero-length segments (consecutive points closer than 1e-12 times its bounding-box
    diagonal). With `drop_degenerate=True` the second point of each zero-length segment is removed
    instead (repeated points collapse to one), and only a curve left with fewer than 2 points is
    rejected.
    """
    if isinstance(curves, np.ndarray) and curves.ndim != 3:
        raise ParameterError(
            f"curves: expected a (K, M, 3) array or a sequence of (M, 3) arrays, "
            f"got an array of shape {curves.shape}"
        )
    if len(curves) == 0:
        raise ParameterError("curves: no curves given")
    cleaned = []
    for k, curve in enumerate(curves):
        try:
            points = np.asarray(curve, dtype=np.float64)
        except (TypeError, ValueError):
            raise ParameterError(f"curve {k}: not a numeric array") from None
        if points.ndim != 2 or points.shape[1] != 3:
            raise ParameterError(f"curve {k}: expected shape (M, 3), got {points.shape}")
        bad = ~np.isfinite(points).all(axis=1)
        if bad.any():
            raise ParameterError(
                f"curve {k}: NaN or Inf coordinates at point(s) {_first_indices(bad)}"
            )
        if len(points) < 2:
            raise ParameterError(f"curve {k}: needs at least 2 points, got {len(points)}")
        lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)
        extent = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
        degenerate = lengths <= _DEGENERATE_REL_TOL * extent
        if degenerate.any():
            if not drop_degenerate:
                raise ParameterError(
                    f"curve {k}: zero-length segment(s) at index {_first_indices(degenerate)} "
                    "(repeated points)"
                )
            points = points[np.concatenate(([True], ~degenerate))]
            if len(points) < 2:
                raise ParameterError(
                    f"curve {k}: fewer than 2 distinct points after dropping zero-length segments"
                )
        cleaned.append(points)
    return cleaned


def _first_indices(mask: np.ndarray, limit: int = 5) -> str:
    """Format the first `limit` True indices of a boolean mask for an error message."""
    idx = np.flatnonzero(mask)
    text = ", ".join(str(i) for i in idx[:limit])
    return text + (f", ... ({len(idx)} in all)" if len(idx) > limit else "")


def segment_pair_solid_angle(
    p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, p4: np.ndarray, *, signed: bool = True
) -> np.ndarray:
    """Solid angle Omega (sr) of segment pairs (p1->p2, p3->p4), Klenin & Langowski 2000.

    Inputs are (..., 3) arrays of segment end points; returns an (...) array. |Omega| / (2 pi) is
    the pair's ACN. With `signed=False` returns |Omega|; otherwise the sign is Klenin &
    Langowski's sign((r34 x r12) . r13), r_ij = p_j - p_i, which makes
    Omega = int int (dr_a x dr_b) . (r_a - r_b) / |r_a - r_b|^3 over the two segments. Pairs
    sharing an end point must be excluded by the caller (the formula is not defined for them).
    """
    p1, p2, p3, p4 = (np.asarray(p, dtype=np.float64) for p in (p1, p2, p3, p4))
    r13, r14, r23, r24 = p3 - p1, p4 - p1, p3 - p2, p4 - p2
    normals = [_unit(np.cross(a, b)) for a, b in ((r13, r14), (r14, r24), (r24, r23), (r23, r13))]
    omega = np.zeros(np.broadcast_shapes(p1.shape, p2.shape, p3.shape, p4.shape)[:-1])
    for k in range(4):
        cos = np.einsum("...i,...i->...", normals[k], normals[(k + 1) % 4])
        omega += np.arcsin(np.clip(cos, -1.0, 1.0))
    if not signed:
        return omega
    return omega * np.sign(np.einsum("...i,...i->...", np.cross(p4 - p3, p2 - p1), r13))


def _unit(v: np.ndarray) -> np.ndarray:
    """Normalize vectors along the last axis; zero vectors stay zero."""
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)


def _add_half_angles(den1: np.ndarray, den2: np.ndarray, det: np.ndarray) -> np.ndarray:
    """|Omega| (sr) = 2 |arg((den1 + i det)(den2 + i det))|; overwrites den1; 0/0 gives 0.

    Valid because the two triangle half angles sum to at most pi in magnitude (|Omega| <= 2 pi
    for a planar parallelogram), so the argument of the product does not wrap around.
    """
    x = den1 * den2
    x -= det * det
    den1 += den2
    den1 *= det
    y = np.abs(den1, out=den1)
    # |arg(x + i y)| = pi/2 - arctan(x / y) for y >= 0 (x / y = +-inf gives 0 or pi).
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x /= y
    np.arctan(x, out=x)
    x *= -2.0
    x += np.pi
    x[np.isnan(x)] = 0.0
    return x


def segment_pair_abs_solid_angle(
    p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, p4: np.ndarray
) -> np.ndarray:
    """|Omega| (sr) of n segment pairs (p1->p2, p3->p4), each (n, 3), by two triangles (VOS 1983).

    Same quantity as `segment_pair_solid_angle(..., signed=False)`, several times faster.
    Pairs sharing an end point give 0.
    """
    r13, r14, r23, r24 = (
        np.ascontiguousarray((a - b).T) for a, b in ((p3, p1), (p4, p1), (p3, p2), (p4, p2))
    )

    def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    l13, l14, l23, l24 = (np.sqrt(dot(r, r)) for r in (r13, r14, r23, r24))
    s = r13 - r23  # p2 - p1
    t = r14 - r13  # p4 - p3
    det = (
        r13[0] * (s[1] * t[2] - s[2] * t[1])
        + r13[1] * (s[2] * t[0] - s[0] * t[2])
        + r13[2] * (s[0] * t[1] - s[1] * t[0])
    )
    d13_24 = dot(r13, r24)
    den1 = l13 * l14 * l24 + dot(r13, r14) * l24 + d13_24 * l14 + dot(r14, r24) * l13
    den2 = l13 * l24 * l23 + d13_24 * l23 + dot(r13, r23) * l24 + dot(r24, r23) * l13
    omega = _add_half_angles(den1, den2, det)
    omega[(l13 == 0) | (l14 == 0) | (l23 == 0) | (l24 == 0)] = 0.0
    return omega


def _abs_solid_angle_grid(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """|Omega| (sr) for every segment of polyline P (m+1, 3) against every segment of Q (n+1, 3).

    Returns an (m, n) array. Triangle solid angles after Van Oosterom & Strackee (1983): the pair's
    parallelogram has corners D[a,b], D[a,b+1], D[a+1,b+1], D[a+1,b] with D[i,j] = Q[j] - P[i];
    both triangles have the same triple product det = r13 . (s x t) (one matrix product over all
    pairs) and denominators built from the shared grids of |D| and neighbouring dot products. The
    half angles add as arg((den1 + i det)(den2 + i det)), exact because |Omega| <= 2 pi for a
    planar parallelogram. Pairs sharing a vertex (D = 0 at a corner) are set to 0.
    """
    A, B, F = slice(None, -1), slice(1, None), slice(None)
    origin = P[0]
    P = P - origin
    Q = Q - origin
    s = P[1:] - P[:-1]
    t = Q[1:] - Q[:-1]
    # det[a, b] = (Q_b - P_a) . (s_a x t_b) = s_a . (t_b x Q_b) - t_b . (P_a x s_a)
    det = np.hstack([s, np.cross(P[:-1], s)]) @ np.hstack([np.cross(t, Q[:-1]), -t]).T
    dx = Q[:, 0] - P[:, 0, None]
    dy = Q[:, 1] - P[:, 1, None]
    dz = Q[:, 2] - P[:, 2, None]
    length = dx * dx
    length += dy * dy
    length += dz * dz
    np.sqrt(length, out=length)

    def dot(rows0: slice, rows1: slice, cols0: slice, cols1: slice) -> np.ndarray:
        out = dx[rows0, cols0] * dx[rows1, cols1]
        out += dy[rows0, cols0] * dy[rows1, cols1]
        out += dz[rows0, cols0] * dz[rows1, cols1]
        return out

    h = dot(F, F, A, B)  # D[i, j] . D[i, j+1]
    v = dot(A, B, F, F)  # D[i, j] . D[i+1, j]
    diag = dot(A, B, A, B)  # D[a, b] . D[a+1, b+1]
    l00, l01, l10, l11 = length[A, A], length[A, B], length[B, A], length[B, B]
    # Triangles (D00, D01, D11) and (D00, D11, D10): den = |a||b||c| + (a.b)|c| + (a.c)|b| + (b.c)|a|
    l0011 = l00 * l11
    den1 = l0011 * l01
    den1 += h[A] * l11
    den1 += diag * l01
    den1 += v[:, B] * l00
    den2 = l0011
    den2 *= l10
    diag *= l10
    den2 += diag
    den2 += v[:, A] * l11
    den2 += h[B] * l00
    x = _add_half_angles(den1, den2, det)
    shared_i, shared_j = np.nonzero(length == 0.0)
    if len(shared_i):
        rows = np.concatenate([shared_i - 1, shared_i - 1, shared_i, shared_i])
        cols = np.concatenate([shared_j - 1, shared_j, shared_j - 1, shared_j])
        keep = (rows >= 0) & (rows < x.shape[0]) & (cols >= 0) & (cols < x.shape[1])
        x[rows[keep], cols[keep]] = 0.0
    return x


def _cross_sum(P: np.ndarray, Q: np.ndarray) -> float:
    """Sum of |Omega| (sr) over all segment pairs between polylines P and Q, in memory blocks."""
    total = 0.0
    for r0 in range(0, len(P) - 1, _ROWS_PER_BLOCK):
        r1 = min(r0 + _ROWS_PER_BLOCK, len(P) - 1)
        for c0 in range(0, len(Q) - 1, _COLS_PER_BLOCK):
            c1 = min(c0 + _COLS_PER_BLOCK, len(Q) - 1)
            total += float(_abs_solid_angle_grid(P[r0 : r1 + 1], Q[c0 : c1 + 1]).sum())
    return total


def _upper_sums(curves: list[np.ndarray]) -> np.ndarray:
    """(K, K) upper-triangular sums of |Omega| (sr): i<j all pairs, i==i non-adjacent pairs once.

    All curves are joined into one vertex list; the "segments" joining consecutive curves are
    zeroed, and so are pairs (g, h) with h < g + 2 (same or adjacent segment, or the lower half).
    """
    k = len(curves)
    verts = np.concatenate(curves)
    curve_of_vertex = np.repeat(np.arange(k), [len(c) for c in curves])
    seg_curve = curve_of_vertex[:-1]
    joins = np.flatnonzero(curve_of_vertex[1:] != seg_curve)
    n_seg = len(verts) - 1
    sums = np.zeros((k, k))
    for r0 in range(0, n_seg, _ROWS_PER_BLOCK):
        r1 = min(r0 + _ROWS_PER_BLOCK, n_seg)
        for c0 in range(r0, n_seg, _COLS_PER_BLOCK):
            c1 = min(c0 + _COLS_PER_BLOCK, n_seg)
            vals = _abs_solid_angle_grid(verts[r0 : r1 + 1], verts[c0 : c1 + 1])
            vals[joins[(joins >= r0) & (joins < r1)] - r0] = 0.0
            vals[:, joins[(joins >= c0) & (joins < c1)] - c0] = 0.0
            if c0 < r1 + 1:  # the block touches the diagonal
                near = vals[:, : r1 + 1 - c0]
                near[np.arange(c0, c0 + near.shape[1]) < np.arange(r0, r1)[:, None] + 2] = 0.0
            row_lab, col_lab = seg_curve[r0:r1], seg_curve[c0:c1]
            row_starts = np.flatnonzero(np.r_[True, row_lab[1:] != row_lab[:-1]])
            col_starts = np.flatnonzero(np.r_[True, col_lab[1:] != col_lab[:-1]])
            block = np.add.reduceat(np.add.reduceat(vals, col_starts, axis=1), row_starts, axis=0)
            sums[np.ix_(row_lab[row_starts], col_lab[col_starts])] += block
    return sums


def acn_pair(a: np.ndarray, b: np.ndarray) -> float:
    """ACN (crossings, dimensionless) between open polylines a (M, 3) and b (N, 3)."""
    a, b = clean_curves([a, b])
    return _cross_sum(a, b) / (2.0 * np.pi)


def acn_self(curve: np.ndarray) -> float:
    """Self ACN (crossings) of one open polyline (M, 3): non-adjacent segment pairs, each once."""
    return float(_upper_sums(clean_curves([curve]))[0, 0]) / (2.0 * np.pi)


def acn_matrix(curves: CurvesLike) -> np.ndarray:
    """(K, K) ACN matrix (crossings): off-diagonal pairwise ACN (symmetric), diagonal self ACN."""
    sums = _upper_sums(clean_curves(curves)) / (2.0 * np.pi)
    return sums + np.triu(sums, 1).T


def acn_total(curves: CurvesLike) -> float:
    """Total ACN (crossings) of the whole tangle: sum of pairwise ACN over i < j plus self ACNs.

    This is the mean number of crossings in a projection of all curves drawn together: every
    unordered pair of segments is counted once (pairs of adjacent segments of one curve
    contribute nothing), i.e. the sum of the upper triangle of `acn_matrix` including its diagonal.
    """
    return float(_upper_sums(clean_curves(curves)).sum()) / (2.0 * np.pi)
