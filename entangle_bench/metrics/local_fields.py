"""Local entanglement fields: ACN and filament count inside small spheres along the filaments.

Around each sample point on a filament, every polyline is clipped exactly to the sphere of the
given diameter (segment-sphere intersection), and two numbers are recorded:
- local ACN: total ACN of the clipped pieces, i.e. every unordered pair of clipped segments once,
  both between different filaments and within one filament (its self term; segments that are
  neighbours on the original polyline are skipped, as in `acn.acn_self`);
- local filament count: the number of distinct filaments entering the sphere (spatial density;
  at least 1, the sample's own filament).
The default 20 mm diameter follows the reference work (Becker et al., PNAS 119:e2209819119, 2022,
Fig. 2D-F). Pair terms use the exact segment-pair solid angle of `acn`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from entangle_bench.config import check_range
from entangle_bench.metrics.acn import CurvesLike, clean_curves, segment_pair_abs_solid_angle

# Sample-segment clipping tests per block, and segment pairs per solid-angle batch.
_CLIP_ENTRIES_PER_BLOCK = 1 << 18
_PAIRS_PER_BATCH = 1 << 17
# Clipped pieces shorter than this fraction of the diameter are dropped (grazing contacts).
_MIN_PIECE_REL = 1e-12


@dataclass(frozen=True)
class LocalFields:
    """Per-sample local ACN (crossings) and filament count inside spheres of `diameter_m`."""

    diameter_m: float
    points: np.ndarray  # (S, 3) sample centres, same unit as the curves (m)
    curve_index: np.ndarray  # (S,) int, filament each sample lies on
    local_acn: np.ndarray  # (S,) float, ACN of the clipped pieces (crossings)
    local_count: np.ndarray  # (S,) int, distinct filaments entering the sphere

    @property
    def mean_acn(self) -> float:
        """Mean local ACN over samples (crossings)."""
        return float(self.local_acn.mean())

    @property
    def max_acn(self) -> float:
        """Largest local ACN over samples (crossings)."""
        return float(self.local_acn.max())

    @property
    def mean_count(self) -> float:
        """Mean number of filaments per sphere."""
        return float(self.local_count.mean())

    @property
    def max_count(self) -> int:
        """Largest number of filaments in one sphere."""
        return int(self.local_count.max())

    def summary(self) -> dict[str, float]:
        """Mean and max of local ACN and local filament count, plus diameter (m) and sample count."""
        return {
            "diameter_m": self.diameter_m,
            "samples": float(len(self.local_acn)),
            "mean_local_acn": self.mean_acn,
            "max_local_acn": self.max_acn,
            "mean_local_count": self.mean_count,
            "max_local_count": float(self.max_count),
        }


def sample_points(
    curves: list[np.ndarray], spacing_m: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """Sample points (S, 3) and their curve indices: every vertex, or every `spacing_m` of arc length.

    With a spacing, each curve is sampled at arc lengths 0, spacing, 2 spacing, ... up to its
    length (its end point only when it falls on that grid).
    """
    if spacing_m is None:
        points = np.concatenate(curves)
        index = np.repeat(np.arange(len(curves)), [len(c) for c in curves])
        return points, index
    check_range("spacing_m", spacing_m, 0.0, None, low_open=True)
    chunks, index = [], []
    for k, curve in enumerate(curves):
        arc = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(curve, axis=0), axis=1))))
        at = np.arange(0.0, arc[-1] * (1 + 1e-12), spacing_m)
        chunks.append(np.column_stack([np.interp(at, arc, curve[:, i]) for i in range(3)]))
        index.append(np.full(len(at), k))
    return np.concatenate(chunks), np.concatenate(index)


def _pairs_within_groups(group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All index pairs (i, j), i < j, of a sorted label array with equal labels."""
    n = len(group)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    ends = np.r_[starts[1:], n]
    group_end = np.repeat(ends, ends - starts)
    partners = group_end - np.arange(n) - 1
    first = np.repeat(np.arange(n), partners)
    offset = np.arange(len(first)) - np.repeat(np.cumsum(partners) - partners, partners)
    return first, first + 1 + offset


def local_fields(
    curves: CurvesLike, diameter_m: float = 0.02, *, spacing_m: float | None = None
) -> LocalFields:
    """Local ACN and filament count in spheres of `diameter_m` (m) centred on filament samples.

    Samples are every vertex (default) or points every `spacing_m` (m) of arc length; see the
    module docstring for what is counted.
    """
    check_range("diameter_m", diameter_m, 0.0, None, low_open=True)
    curves = clean_curves(curves)
    n_curves = len(curves)
    centres, centre_curve = sample_points(curves, spacing_m)
    radius = 0.5 * diameter_m
    start = np.concatenate([c[:-1] for c in curves])
    direction = np.concatenate([np.diff(c, axis=0) for c in curves])
    seg_curve = np.repeat(np.arange(n_curves), [len(c) - 1 for c in curves])
    seg_index = np.concatenate([np.arange(len(c) - 1) for c in curves])
    seg_len2 = np.einsum("ij,ij->i", direction, direction)
    min_piece = _MIN_PIECE_REL * diameter_m / np.sqrt(seg_len2)

    n_samples = len(centres)
    local_acn = np.zeros(n_samples)
    local_count = np.zeros(n_samples, dtype=np.int64)
    block = max(1, _CLIP_ENTRIES_PER_BLOCK // len(start))
    for s0 in range(0, n_samples, block):
        s1 = min(s0 + block, n_samples)
        # Segment p(t) = start + t direction, t in [0, 1], inside |p - c| <= radius.
        w = start[None, :, :] - centres[s0:s1, None, :]
        half_b = np.einsum("sgi,gi->sg", w, direction)
        c_term = np.einsum("sgi,sgi->sg", w, w) - radius * radius
        disc = half_b * half_b - seg_len2 * c_term
        sample, seg = np.nonzero(disc > 0.0)
        root = np.sqrt(disc[sample, seg])
        t_lo = np.maximum((-half_b[sample, seg] - root) / seg_len2[seg], 0.0)
        t_hi = np.minimum((-half_b[sample, seg] + root) / seg_len2[seg], 1.0)
        inside = t_hi - t_lo > min_piece[seg]
        sample, seg, t_lo, t_hi = sample[inside], seg[inside], t_lo[inside], t_hi[inside]
        sample += s0
        keys = np.unique(sample * n_curves + seg_curve[seg])
        local_count += np.bincount(keys // n_curves, minlength=n_samples)
        piece_a = start[seg] + t_lo[:, None] * direction[seg]
        piece_b = start[seg] + t_hi[:, None] * direction[seg]
        # Pair up the pieces of each sphere, a few spheres at a time to bound memory.
        hits = np.bincount(sample - s0, minlength=s1 - s0)
        hit_start = np.r_[0, np.cumsum(hits)]
        pairs_before = np.cumsum(hits * (hits - 1) // 2) - hits * (hits - 1) // 2
        batch_of_sample = pairs_before // _PAIRS_PER_BATCH
        cuts = np.r_[0, np.flatnonzero(np.diff(batch_of_sample)) + 1, s1 - s0]
        for a, b in itertools.pairwise(cuts):
            h0, h1 = hit_start[a], hit_start[b]
            first, second = _pairs_within_groups(sample[h0:h1])
            first += h0
            second += h0
            keep = (seg_curve[seg[first]] != seg_curve[seg[second]]) | (
                np.abs(seg_index[seg[first]] - seg_index[seg[second]]) > 1
            )
            first, second = first[keep], second[keep]
            for p0 in range(0, len(first), _PAIRS_PER_BATCH):
                i = first[p0 : p0 + _PAIRS_PER_BATCH]
                j = second[p0 : p0 + _PAIRS_PER_BATCH]
                omega = segment_pair_abs_solid_angle(piece_a[i], piece_b[i], piece_a[j], piece_b[j])
                local_acn += np.bincount(sample[i], weights=omega, minlength=n_samples)
    return LocalFields(
        diameter_m=float(diameter_m),
        points=centres,
        curve_index=centre_curve,
        local_acn=local_acn / (2.0 * np.pi),
        local_count=local_count,
    )
