"""Branched objects built from capsules on a cylindrical trunk and base disc (no decomposition).

`eight_branch_tree` is the reference test object; `random_tree` a seeded procedural stand-in for a
small plant or coral. Both stand on a thin base disc so that they stay upright when dropped.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from entangle_bench.config import check_range
from entangle_bench.errors import ParameterError
from entangle_bench.objects.catalog import register_object
from entangle_bench.objects.geometry import Capsule, Cylinder, Part, Shape


def _direction(azimuth_rad: float, elevation_rad: float) -> np.ndarray:
    """Unit vector at `azimuth_rad` around z and `elevation_rad` above the horizontal."""
    return np.array([math.cos(elevation_rad) * math.cos(azimuth_rad),
                     math.cos(elevation_rad) * math.sin(azimuth_rad), math.sin(elevation_rad)])


def _trunk_and_base(trunk_height_m: float, trunk_radius_m: float, base_radius_m: float,
                    base_thickness_m: float) -> tuple[list[Part], float]:
    """Return the base disc (if any) and trunk cylinder, and the z (m) where the trunk rises from the base.

    The trunk cylinder starts halfway inside the base disc rather than on its top face: two flush faces of
    one rigid body form a zero-width pocket in which a filament can be squeezed between them, an artificial
    clamp (measured: +4.7 W on one face, -4.5 W on the other). Overlapping parts count once in the mass.
    """
    parts: list[Part] = []
    z0 = 0.0
    if base_radius_m > 0:
        parts.append(Cylinder("base", (0.0, 0.0, 0.0), (0.0, 0.0, base_thickness_m), base_radius_m))
        z0 = base_thickness_m
    parts.append(Cylinder("trunk", (0.0, 0.0, z0 / 2), (0.0, 0.0, z0 + trunk_height_m), trunk_radius_m))
    return parts, z0


@dataclasses.dataclass(frozen=True)
class EightBranchTreeParams:
    """Reference tree: a trunk with `branch_count` straight branches in whorls, on a base disc.

    Assumed reference shape (the exact dimensions of the physical test object are not published
    with this harness): trunk 130 mm x 6 mm radius, 8 branches of 50 mm x 3 mm radius at 30 deg
    elevation in 2 whorls of 4 (at 45 % and 85 % of the trunk height, turned 45 deg to each other
    so the branches point in 8 directions seen from above), a 30 mm radius x 4 mm base disc, and
    30 g in total (about 830 kg/m^3, i.e. a 3D print with partial infill).
    `branch_length_m` is measured from the trunk surface to the tip of the rounded branch end.
    """

    trunk_height_m: float = 0.13
    trunk_radius_m: float = 0.006
    branch_count: int = 8
    branch_length_m: float = 0.05
    branch_radius_m: float = 0.003
    branch_elevation_deg: float = 30.0
    whorl_count: int = 2
    lowest_whorl_fraction: float = 0.45
    highest_whorl_fraction: float = 0.85
    base_radius_m: float = 0.03
    base_thickness_m: float = 0.004
    mass_kg: float = 0.03

    def __post_init__(self):
        check_range("trunk_height_m", self.trunk_height_m, 0.01, 1.0)
        check_range("trunk_radius_m", self.trunk_radius_m, 0.0005, 0.05)
        check_range("branch_count", self.branch_count, 0, 64)
        if not isinstance(self.branch_count, int) or not isinstance(self.whorl_count, int):
            raise ParameterError("branch_count and whorl_count must be integers")
        check_range("branch_length_m", self.branch_length_m, 0.0, 0.5, low_open=True)
        check_range("branch_radius_m", self.branch_radius_m, 0.0003, self.trunk_radius_m)
        check_range("branch_elevation_deg", self.branch_elevation_deg, -60.0, 85.0)
        check_range("whorl_count", self.whorl_count, 1, max(1, self.branch_count))
        check_range("lowest_whorl_fraction", self.lowest_whorl_fraction, 0.0, 1.0)
        check_range("highest_whorl_fraction", self.highest_whorl_fraction,
                    self.lowest_whorl_fraction, 1.0)
        check_range("base_radius_m", self.base_radius_m, 0.0, 0.2)
        check_range("base_thickness_m", self.base_thickness_m, 0.0005, 0.05)
        check_range("mass_kg", self.mass_kg, 0.0, 10.0, low_open=True)


@register_object(
    "eight_branch_tree", EightBranchTreeParams(), "reference tree: trunk with 8 capsule branches on a base disc"
)
def build_eight_branch_tree(p: EightBranchTreeParams) -> Shape:
    """Shape of the reference tree (trunk axis = z, base bottom at z = 0)."""
    parts, z0 = _trunk_and_base(p.trunk_height_m, p.trunk_radius_m, p.base_radius_m,
                                p.base_thickness_m)
    elevation = math.radians(p.branch_elevation_deg)
    reach = p.trunk_radius_m + p.branch_length_m - p.branch_radius_m
    if reach <= 0:
        raise ParameterError("branch_length_m too short: the branch ends inside the trunk")
    for k in range(p.branch_count):
        whorl = k % p.whorl_count
        frac = p.lowest_whorl_fraction + (p.highest_whorl_fraction - p.lowest_whorl_fraction) * (
            whorl / (p.whorl_count - 1) if p.whorl_count > 1 else 1.0)
        root = np.array([0.0, 0.0, z0 + frac * p.trunk_height_m])
        tip = root + reach * _direction(2 * math.pi * k / p.branch_count, elevation)
        parts.append(Capsule(f"branch{k:02d}", tuple(root), tuple(tip), p.branch_radius_m))
    dims = {
        "trunk_height_m": p.trunk_height_m,
        "trunk_radius_m": p.trunk_radius_m,
        "branch_length_m": p.branch_length_m,
        "branch_radius_m": p.branch_radius_m,
        "base_radius_m": p.base_radius_m,
        "base_thickness_m": p.base_thickness_m,
    }
    return Shape(tuple(parts), p.mass_kg, dims, axis_xy=(0.0, 0.0))


@dataclasses.dataclass(frozen=True)
class RandomTreeParams:
    """Seeded procedural tree: every segment sprouts `children_min..children_max` thinner, shorter
    capsule branches along its upper part, `levels` times; branches point upwards
    (`elevation_min_deg..elevation_max_deg`). Defaults: a 100 mm sprig weighing 25 g.
    """

    seed: int = 0
    trunk_height_m: float = 0.10
    trunk_radius_m: float = 0.005
    levels: int = 2
    children_min: int = 2
    children_max: int = 4
    length_ratio: float = 0.55
    radius_ratio: float = 0.65
    min_radius_m: float = 0.0015
    elevation_min_deg: float = 10.0
    elevation_max_deg: float = 60.0
    base_radius_m: float = 0.03
    base_thickness_m: float = 0.004
    mass_kg: float = 0.025

    def __post_init__(self):
        for name in ("seed", "levels", "children_min", "children_max"):
            if not isinstance(getattr(self, name), int):
                raise ParameterError(f"{name} must be an integer")
        check_range("seed", self.seed, 0, None)
        check_range("trunk_height_m", self.trunk_height_m, 0.01, 1.0)
        check_range("trunk_radius_m", self.trunk_radius_m, 0.0005, 0.05)
        check_range("levels", self.levels, 0, 3)
        check_range("children_min", self.children_min, 1, 6)
        check_range("children_max", self.children_max, self.children_min, 6)
        check_range("length_ratio", self.length_ratio, 0.1, 1.0)
        check_range("radius_ratio", self.radius_ratio, 0.1, 1.0)
        check_range("min_radius_m", self.min_radius_m, 0.0003, self.trunk_radius_m)
        check_range("elevation_min_deg", self.elevation_min_deg, 0.0, 85.0)
        check_range("elevation_max_deg", self.elevation_max_deg, self.elevation_min_deg, 85.0)
        check_range("base_radius_m", self.base_radius_m, 0.0, 0.2)
        check_range("base_thickness_m", self.base_thickness_m, 0.0005, 0.05)
        check_range("mass_kg", self.mass_kg, 0.0, 10.0, low_open=True)


@register_object("random_tree", RandomTreeParams(), "seeded procedural tree (plant / coral stand-in)")
def build_random_tree(p: RandomTreeParams) -> Shape:
    """Shape of the seeded procedural tree (trunk axis = z, base bottom at z = 0)."""
    rng = np.random.default_rng(p.seed)
    parts, z0 = _trunk_and_base(p.trunk_height_m, p.trunk_radius_m, p.base_radius_m,
                                p.base_thickness_m)
    start = np.array([0.0, 0.0, z0])
    # segment: (start, end, radius, length, azimuth or None for the vertical trunk)
    frontier = [(start, start + [0.0, 0.0, p.trunk_height_m], p.trunk_radius_m, p.trunk_height_m,
                 None)]
    lo, hi = math.radians(p.elevation_min_deg), math.radians(p.elevation_max_deg)
    count = 0  # branches made so far; names them
    for _ in range(p.levels):
        children = []
        for seg_start, seg_end, radius, length, azimuth in frontier:
            n = int(rng.integers(p.children_min, p.children_max + 1))
            phase = rng.uniform(0, 2 * math.pi)
            for i in range(n):
                if azimuth is None:
                    az = phase + 2 * math.pi * i / n + rng.uniform(-0.3, 0.3)
                else:
                    az = azimuth + rng.uniform(-1.0, 1.0)
                root = seg_start + rng.uniform(0.4, 1.0) * (seg_end - seg_start)
                child_len = length * p.length_ratio * rng.uniform(0.8, 1.2)
                child_r = max(p.min_radius_m, radius * p.radius_ratio)
                tip = root + child_len * _direction(az, rng.uniform(lo, hi))
                parts.append(Capsule(f"branch{count:02d}", tuple(root), tuple(tip), child_r))
                children.append((root, tip, child_r, child_len, az))
                count += 1
        frontier = children
    dims = {
        "trunk_height_m": p.trunk_height_m,
        "trunk_radius_m": p.trunk_radius_m,
        "base_radius_m": p.base_radius_m,
        "base_thickness_m": p.base_thickness_m,
    }
    return Shape(tuple(parts), p.mass_kg, dims, axis_xy=(0.0, 0.0))
