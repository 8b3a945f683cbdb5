"""Plot filament curves colored by local ACN and local filament density, plus contact points.

Three 3D panels in the style of Becker et al. (PNAS 2022) Fig. 2D-F: filaments colored by local
ACN, by local filament count (spheres of --diameter, default 20 mm, at every vertex), and contact
points colored by kind (filament-object red, filament-filament blue), each with the object drawn in.
Reads an .npz with `curves` (K, M, 3) in m (or one (M, 3) array per key) and optionally
`contact_points` (n, 3), `contact_kinds` (n,) and the object's parts (`entangle_bench.viz.pack`, as
the runner saves them in states/*.npz); never simulates.

Usage:
    python scripts/plot_entanglement.py FILE.npz --out fig.png
    python scripts/plot_entanglement.py --demo --out demo.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from entangle_bench.atomic import atomic_savefig
from entangle_bench.errors import EntangleBenchError
from entangle_bench.metrics.curve_file import load_contacts, load_curves
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.metrics.synthetic import helix_tangle
from entangle_bench.viz import KIND_COLORS, Part, draw_scene, set_equal_axes, unpack

DEMO_OBJECT_RADIUS_M = 0.015
DEMO_OBJECT_HEIGHT_M = 0.12


def demo_data() -> tuple[list[np.ndarray], np.ndarray, np.ndarray, list[Part]]:
    """Intertwined helices around a cylinder of radius 15 mm, with geometric stand-in contacts.

    Contacts are not simulated: filament-filament points are midpoints of vertex pairs of
    different filaments closer than 3 mm, filament-object points are vertices within 2 mm of the
    cylinder, projected onto it.
    """
    curves = helix_tangle(12, 101, radius_m=0.02, noise_m=0.002)
    verts = curves.reshape(-1, 3)
    owner = np.repeat(np.arange(len(curves)), curves.shape[1])
    dist = np.linalg.norm(verts[:, None] - verts[None], axis=2)
    i, j = np.nonzero((dist < 0.003) & (owner[:, None] < owner[None, :]))
    ff = 0.5 * (verts[i] + verts[j])
    rho = np.linalg.norm(verts[:, :2], axis=1)
    near = np.abs(rho - DEMO_OBJECT_RADIUS_M) < 0.002
    fo = verts[near].copy()
    fo[:, :2] *= (DEMO_OBJECT_RADIUS_M / rho[near])[:, None]
    points = np.vstack([ff, fo])
    kinds = np.array(["filament-filament"] * len(ff) + ["filament-object"] * len(fo))
    half = DEMO_OBJECT_HEIGHT_M / 2
    cylinder = Part("cylinder", np.array([DEMO_OBJECT_RADIUS_M, half, 0.0]), np.array([0.0, 0.0, half]),
                    np.eye(3), np.zeros((0, 3)), np.zeros((0, 3), np.int32))
    return list(curves), points, kinds, [cylinder]


def _frame(ax, points_mm: np.ndarray) -> None:
    """Equal axes around the drawn points (mm), one view for every panel."""
    set_equal_axes(ax, points_mm)
    ax.view_init(elev=18, azim=-60)


def _colored_curves(ax, curves_mm, values, cmap, norm, width=2.0) -> None:
    """Draw each polyline with segments colored by the mean of their end-vertex values."""
    start = 0
    for curve in curves_mm:
        vals = values[start : start + len(curve)]
        start += len(curve)
        segments = np.stack([curve[:-1], curve[1:]], axis=1)
        lines = Line3DCollection(segments, cmap=cmap, norm=norm, linewidths=width)
        lines.set_array(0.5 * (vals[:-1] + vals[1:]))
        ax.add_collection(lines)


def plot(
    curves: list[np.ndarray],
    contacts: tuple[np.ndarray, np.ndarray] | None,
    parts: list[Part],
    diameter_m: float,
    out: Path,
    title: str,
) -> None:
    """Draw the three panels, each with the object's parts, and save the PNG atomically."""
    fields = local_fields(curves, diameter_m=diameter_m)
    curves_mm = [1e3 * c for c in curves]
    all_mm = np.concatenate(curves_mm)
    fig = plt.figure(figsize=(16, 5.6))
    fig.suptitle(title)

    ax = fig.add_subplot(1, 3, 1, projection="3d")
    all_mm = np.vstack([all_mm, draw_scene(ax, parts=parts, ground=False, object_alpha=0.35)])
    norm = plt.Normalize(0.0, max(fields.max_acn, 1e-9))
    _colored_curves(ax, curves_mm, fields.local_acn, "plasma", norm)
    fig.colorbar(
        plt.cm.ScalarMappable(norm=norm, cmap="plasma"),
        ax=ax,
        shrink=0.6,
        pad=0.1,
        label="local ACN",
    )
    ax.set_title(
        f"local ACN ({diameter_m * 1e3:.0f} mm spheres)\n"
        f"mean {fields.mean_acn:.2f}, max {fields.max_acn:.2f}"
    )
    _frame(ax, all_mm)

    ax = fig.add_subplot(1, 3, 2, projection="3d")
    draw_scene(ax, parts=parts, ground=False, object_alpha=0.35)
    top = max(fields.max_count, 2)
    cmap = plt.get_cmap("viridis", top)
    norm = matplotlib.colors.BoundaryNorm(np.arange(0.5, top + 1.0), top)
    _colored_curves(ax, curves_mm, fields.local_count.astype(float), cmap, norm)
    fig.colorbar(
        plt.cm.ScalarMappable(norm=norm, cmap=cmap),
        ax=ax,
        shrink=0.6,
        pad=0.1,
        ticks=np.arange(1, top + 1),
        label="filaments in sphere",
    )
    ax.set_title(f"local filament density\nmean {fields.mean_count:.2f}, max {fields.max_count}")
    _frame(ax, all_mm)

    ax = fig.add_subplot(1, 3, 3, projection="3d")
    has_contacts = contacts is not None and len(contacts[0]) > 0
    all_mm = np.vstack([all_mm, draw_scene(ax, curves, parts, contacts if has_contacts else None, ground=False,
                                           curve_color="0.75", object_alpha=0.35)])
    if has_contacts:
        kinds = contacts[1]
        handles = [Line2D([], [], marker="o", linestyle="", color=color, label=f"{kind} ({(kinds == kind).sum()})")
                   for kind, color in KIND_COLORS.items() if (kinds == kind).any()]
        ax.set_title("contacts by kind")
        ax.legend(handles=handles, loc="upper left", fontsize=8)
    else:
        ax.set_title("contacts\n(no contact data in file)")
    _frame(ax, all_mm)

    fig.tight_layout()
    try:
        atomic_savefig(fig, out, dpi=110)
    finally:
        plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """Parse arguments, load or synthesize data, write the PNG; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", help=".npz with `curves` (m) and optional contacts")
    parser.add_argument("--demo", action="store_true", help="plot a synthetic tangle instead")
    parser.add_argument("--out", required=True, help="output PNG path")
    parser.add_argument(
        "--diameter", type=float, default=0.02, help="local-field sphere diameter, m (default 0.02)"
    )
    args = parser.parse_args(argv)
    if args.demo == (args.file is not None):
        parser.error("give either FILE or --demo")
    try:
        if args.demo:
            curves, points, kinds, parts = demo_data()
            contacts = (points, kinds)
            title = "demo: 12 intertwined helices (contacts: geometric stand-ins, not simulated)"
        else:
            curves = load_curves(args.file).curves
            contacts = load_contacts(args.file)
            with np.load(args.file, allow_pickle=False) as arrays:
                parts = unpack(arrays)
            title = str(args.file)
        plot(curves, contacts, parts, args.diameter, Path(args.out), title)
    except EntangleBenchError as exc:
        print(f"plot_entanglement: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
