"""Plot filament curves colored by local ACN and local filament density, plus contact points.

Three 3D panels in the style of Becker et al. (PNAS 2022) Fig. 2D-F: filaments colored by local
ACN, by local filament count (spheres of --diameter, default 20 mm, at every vertex), and contact
points colored by kind (filament-object red, filament-filament blue). Reads an .npz with `curves`
(K, M, 3) in m (or one (M, 3) array per key) and optionally `contact_points` (n, 3) and
`contact_kinds` (n,); never simulates.

Usage:
    python scripts/plot_entanglement.py FILE.npz --out fig.png
    python scripts/plot_entanglement.py --demo --out demo.png
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from entangle_bench.errors import EntangleBenchError
from entangle_bench.metrics.curve_file import load_contacts, load_curves
from entangle_bench.metrics.local_fields import local_fields
from entangle_bench.metrics.synthetic import helix_tangle

KIND_COLORS = {
    "filament-object": "tab:red",
    "filament-filament": "tab:blue",
    "filament-self": "tab:purple",
    "filament-ground": "tab:green",
    "object-ground": "tab:gray",
    "other": "black",
}
DEMO_OBJECT_RADIUS_M = 0.015


def demo_data() -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
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
    return list(curves), points, kinds


def _set_equal_axes(ax, points_mm: np.ndarray) -> None:
    """Equal scale on x, y, z around the data, labelled in mm."""
    lo, hi = points_mm.min(axis=0), points_mm.max(axis=0)
    center, half = 0.5 * (lo + hi), 0.5 * max(float((hi - lo).max()), 1e-9)
    ax.set_xlim(center[0] - half, center[0] + half)
    ax.set_ylim(center[1] - half, center[1] + half)
    ax.set_zlim(center[2] - half, center[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
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
    diameter_m: float,
    out: Path,
    title: str,
) -> None:
    """Draw the three panels and save the PNG atomically."""
    fields = local_fields(curves, diameter_m=diameter_m)
    curves_mm = [1e3 * c for c in curves]
    all_mm = np.concatenate(curves_mm)
    fig = plt.figure(figsize=(16, 5.6))
    fig.suptitle(title)

    ax = fig.add_subplot(1, 3, 1, projection="3d")
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
    _set_equal_axes(ax, all_mm)

    ax = fig.add_subplot(1, 3, 2, projection="3d")
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
    _set_equal_axes(ax, all_mm)

    ax = fig.add_subplot(1, 3, 3, projection="3d")
    for curve in curves_mm:
        ax.plot(*curve.T, color="0.75", linewidth=1.0)
    handles = []
    if contacts is None or len(contacts[0]) == 0:
        ax.set_title("contacts\n(no contact data in file)")
    else:
        points_mm, kinds = 1e3 * contacts[0], contacts[1]
        for kind, color in KIND_COLORS.items():
            sel = kinds == kind
            if sel.any():
                ax.scatter(*points_mm[sel].T, color=color, s=10, depthshade=False)
                handles.append(
                    Line2D(
                        [], [], marker="o", linestyle="", color=color, label=f"{kind} ({sel.sum()})"
                    )
                )
        ax.set_title("contacts by kind")
        ax.legend(handles=handles, loc="upper left", fontsize=8)
        all_mm = np.vstack([all_mm, points_mm])
    _set_equal_axes(ax, all_mm)

    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.stem}-", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=110)
        os.replace(tmp, out)
    finally:
        plt.close(fig)
        if os.path.exists(tmp):
            os.remove(tmp)


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
            curves, points, kinds = demo_data()
            contacts = (points, kinds)
            title = "demo: 12 intertwined helices (contacts: geometric stand-ins, not simulated)"
        else:
            curves = load_curves(args.file).curves
            contacts = load_contacts(args.file)
            title = str(args.file)
        plot(curves, contacts, args.diameter, Path(args.out), title)
    except EntangleBenchError as exc:
        print(f"plot_entanglement: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
