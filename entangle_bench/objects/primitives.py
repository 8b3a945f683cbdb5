"""Objects made of MuJoCo primitives: balls, cylinders and tubes, a horizontal rod, a cube and a bar-clamp bracket.

Masses are plausible assumptions for everyday test objects, documented on each params class.
"""

from __future__ import annotations

import dataclasses
import math

from entangle_bench.config import check_range
from entangle_bench.errors import ParameterError
from entangle_bench.objects.catalog import register_object
from entangle_bench.objects.geometry import Box, Cylinder, Part, Shape, Sphere


@dataclasses.dataclass(frozen=True)
class SphereParams:
    """Ball of `diameter_m`; with `shell_thickness_m` its mass sits in a shell (hollow ball).

    Defaults (`sphere`): a light hollow plastic ball, 100 mm, 50 g, 2 mm wall (assumed).
    `tennis_ball`: 67 mm, 58 g (ITF: 65.4-68.6 mm, 56.0-59.4 g), 6 mm rubber-and-felt wall.
    """

    diameter_m: float = 0.10
    mass_kg: float = 0.05
    shell_thickness_m: float | None = 0.002

    def __post_init__(self):
        check_range("diameter_m", self.diameter_m, 0.002, 1.0)
        check_range("mass_kg", self.mass_kg, 0.0, 20.0, low_open=True)
        if self.shell_thickness_m is not None:
            check_range("shell_thickness_m", self.shell_thickness_m, 0.0, self.diameter_m / 2,
                        low_open=True)


@register_object("sphere", SphereParams(), "100 mm light hollow ball, 50 g")
@register_object("tennis_ball", SphereParams(0.067, 0.058, 0.006), "tennis ball, 67 mm, 58 g")
def build_sphere(p: SphereParams) -> Shape:
    """Shape of a ball resting on its bottom point."""
    r = p.diameter_m / 2
    ball = Sphere("ball", (0.0, 0.0, r), r, p.shell_thickness_m)
    dims = {"diameter_m": p.diameter_m}
    if p.shell_thickness_m is not None:
        dims["shell_thickness_m"] = p.shell_thickness_m
    return Shape((ball,), p.mass_kg, dims, orientation_free=True)


@dataclasses.dataclass(frozen=True)
class CylinderParams:
    """Upright cylinder of `diameter_m` x `height_m`; with `wall_thickness_m` an open tube.

    A tube is a ring of `wall_segments` boxes (a regular polygon of the outer diameter) so that
    filaments can thread through it. Assumed masses: solid cylinders are 3D prints with sparse
    infill (about 440 kg/m^3: 50 g for 38 mm, 90 g for 51 mm x 100 mm); the 51 mm tube has solid
    PLA walls of 3 mm (1240 kg/m^3, 56 g).
    """

    diameter_m: float = 0.038
    height_m: float = 0.10
    mass_kg: float = 0.05
    wall_thickness_m: float | None = None
    wall_segments: int = 16

    def __post_init__(self):
        check_range("diameter_m", self.diameter_m, 0.002, 1.0)
        check_range("height_m", self.height_m, 0.001, 1.0)
        check_range("mass_kg", self.mass_kg, 0.0, 20.0, low_open=True)
        if self.wall_thickness_m is not None:
            check_range("wall_thickness_m", self.wall_thickness_m, 0.0, self.diameter_m / 2,
                        low_open=True, high_open=True)
        if not isinstance(self.wall_segments, int):
            raise ParameterError("wall_segments must be an integer")
        check_range("wall_segments", self.wall_segments, 6, 64)


@register_object("cylinder_38", CylinderParams(0.038, 0.10, 0.05), "upright cylinder, 38 mm x 100 mm, 50 g")
@register_object("cylinder_51", CylinderParams(0.051, 0.10, 0.09), "upright cylinder, 51 mm x 100 mm, 90 g")
@register_object(
    "cylinder_51_hollow",
    CylinderParams(0.051, 0.10, 0.056, wall_thickness_m=0.003),
    "open tube, 51 mm outer diameter, 3 mm wall, 100 mm long",
)
def build_cylinder(p: CylinderParams) -> Shape:
    """Shape of an upright cylinder or tube standing on its flat end."""
    r = p.diameter_m / 2
    dims = {"diameter_m": p.diameter_m, "height_m": p.height_m}
    if p.wall_thickness_m is None:
        return Shape((Cylinder("body", (0.0, 0.0, 0.0), (0.0, 0.0, p.height_m), r),), p.mass_kg,
                     dims)
    t = p.wall_thickness_m
    n = p.wall_segments
    half_angle = math.pi / n
    # each box spans the polygon's side at the outer radius r (apothem) and reaches t inwards
    mid = r - t / 2
    half_len = r * math.tan(half_angle)
    parts: list[Part] = []
    for i in range(n):
        a = 2 * math.pi * i / n
        quat = (math.cos(a / 2), 0.0, 0.0, math.sin(a / 2))
        parts.append(Box(f"wall{i:02d}", (mid * math.cos(a), mid * math.sin(a), p.height_m / 2),
                         (t / 2, half_len, p.height_m / 2), quat))
    dims["wall_thickness_m"] = t
    return Shape(tuple(parts), p.mass_kg, dims)


@dataclasses.dataclass(frozen=True)
class RodParams:
    """Horizontal rod of `diameter_m` x `length_m` lying along y; default a 10 mm x 150 mm aluminium bar (30 g)."""

    diameter_m: float = 0.010
    length_m: float = 0.15
    mass_kg: float = 0.03

    def __post_init__(self):
        for name, low, high in (("diameter_m", 0.001, 0.5), ("length_m", 0.002, 2.0)):
            check_range(name, getattr(self, name), low, high)
        check_range("mass_kg", self.mass_kg, 0.0, 20.0, low_open=True)


@register_object("rod", RodParams(), "horizontal rod (bar) lying along y, 10 mm x 150 mm, 30 g")
def build_rod(p: RodParams) -> Shape:
    """Shape of a cylinder lying on its side with its axis along y."""
    r, half = p.diameter_m / 2, p.length_m / 2
    rod = Cylinder("rod", (0.0, -half, r), (0.0, half, r), r)
    return Shape((rod,), p.mass_kg, {"diameter_m": p.diameter_m, "length_m": p.length_m})


@dataclasses.dataclass(frozen=True)
class CubeParams:
    """Cube of `edge_m`; default a 50 mm wooden block of 75 g (600 kg/m^3, assumed)."""

    edge_m: float = 0.05
    mass_kg: float = 0.075

    def __post_init__(self):
        check_range("edge_m", self.edge_m, 0.002, 1.0)
        check_range("mass_kg", self.mass_kg, 0.0, 20.0, low_open=True)


@register_object("cube", CubeParams(), "50 mm cube, 75 g")
def build_cube(p: CubeParams) -> Shape:
    """Shape of a cube resting on a face."""
    h = p.edge_m / 2
    return Shape((Box("cube", (0.0, 0.0, h), (h, h, h)),), p.mass_kg, {"edge_m": p.edge_m})


@dataclasses.dataclass(frozen=True)
class BracketParams:
    """Bar clamp lying flat: a bar along x, two jaws along +y (a C shape) and a pistol-grip
    handle cylinder below the sliding jaw along -y. All parts rest on the ground.

    Assumed defaults: 150 x 15 x 8 mm bar, 60 mm jaws 80 mm apart, 50 mm x 10 mm radius handle,
    100 g (about 1900 kg/m^3, glass-filled nylon with steel inserts).
    """

    bar_length_m: float = 0.15
    bar_width_m: float = 0.015
    thickness_m: float = 0.008
    jaw_length_m: float = 0.06
    jaw_width_m: float = 0.015
    jaw_gap_m: float = 0.08
    handle_length_m: float = 0.05
    handle_radius_m: float = 0.01
    mass_kg: float = 0.10

    def __post_init__(self):
        check_range("bar_length_m", self.bar_length_m, 0.01, 1.0)
        check_range("bar_width_m", self.bar_width_m, 0.001, 0.2)
        check_range("thickness_m", self.thickness_m, 0.001, 0.2)
        check_range("jaw_length_m", self.jaw_length_m, 0.001, 0.5)
        check_range("jaw_width_m", self.jaw_width_m, 0.001, 0.2)
        check_range("jaw_gap_m", self.jaw_gap_m, 0.0, self.bar_length_m - 2 * self.jaw_width_m,
                    low_open=True)
        check_range("handle_length_m", self.handle_length_m, 0.0, 0.5)
        check_range("handle_radius_m", self.handle_radius_m, 0.001, 0.1)
        check_range("mass_kg", self.mass_kg, 0.0, 20.0, low_open=True)


@register_object("bracket", BracketParams(), "bar clamp lying flat (bar, two jaws, handle)")
def build_bracket(p: BracketParams) -> Shape:
    """Shape of the flat-lying bar clamp."""
    t2 = p.thickness_m / 2
    x_fixed = p.bar_length_m / 2 - p.jaw_width_m / 2
    x_slide = x_fixed - p.jaw_width_m - p.jaw_gap_m
    # jaws span y in [-bar_width/2, bar_width/2 + jaw_length]
    jaw_y = p.jaw_length_m / 2
    jaw_half = (p.bar_width_m + p.jaw_length_m) / 2
    parts: list[Part] = [
        Box("bar", (0.0, 0.0, t2), (p.bar_length_m / 2, p.bar_width_m / 2, t2)),
        Box("jaw_fixed", (x_fixed, jaw_y, t2), (p.jaw_width_m / 2, jaw_half, t2)),
        Box("jaw_sliding", (x_slide, jaw_y, t2), (p.jaw_width_m / 2, jaw_half, t2)),
    ]
    if p.handle_length_m > 0:
        y0 = -p.bar_width_m / 2
        z = p.handle_radius_m
        parts.append(Cylinder("handle", (x_slide, y0, z), (x_slide, y0 - p.handle_length_m, z),
                              p.handle_radius_m))
    dims = {
        "bar_length_m": p.bar_length_m,
        "bar_width_m": p.bar_width_m,
        "thickness_m": p.thickness_m,
        "jaw_length_m": p.jaw_length_m,
        "jaw_gap_m": p.jaw_gap_m,
        "handle_length_m": p.handle_length_m,
        "handle_radius_m": p.handle_radius_m,
    }
    return Shape(tuple(parts), p.mass_kg, dims)
