"""Matplotlib 3D picture of an object's collision geoms, saved as PNG."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import trimesh
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from entangle_bench.objects.geometry import (
    Box,
    Capsule,
    ConvexMesh,
    Cylinder,
    Part,
    Sphere,
    quat_to_matrix,
)
from entangle_bench.objects.registry import build


def _segment_transform(p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """4x4 transform taking a z-aligned shape centred at the origin onto segment p0-p1."""
    axis = p1 - p0
    z = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    t = np.eye(4)
    t[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    t[:3, 3] = (p0 + p1) / 2
    return t


def surface(part: Part) -> tuple[np.ndarray, np.ndarray]:
    """Triangle surface (vertices in m, faces) of a part, for drawing."""
    if isinstance(part, Capsule):
        p0, p1 = np.asarray(part.p0), np.asarray(part.p1)
        mesh = trimesh.creation.capsule(height=float(np.linalg.norm(p1 - p0)), radius=part.radius,
                                        count=[12, 12])
        mesh.apply_transform(_segment_transform(p0, p1))
    elif isinstance(part, Cylinder):
        mesh = trimesh.creation.cylinder(radius=part.radius, segment=[part.p0, part.p1],
                                         sections=32)
    elif isinstance(part, Sphere):
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=part.radius)
        mesh.apply_translation(part.center)
    elif isinstance(part, Box):
        t = np.eye(4)
        t[:3, :3] = quat_to_matrix(part.quat)
        t[:3, 3] = part.center
        mesh = trimesh.creation.box(extents=2 * np.asarray(part.half), transform=t)
    elif isinstance(part, ConvexMesh):
        return part.vertices, part.faces
    else:
        raise TypeError(f"unsupported part {type(part).__name__}")
    return np.asarray(mesh.vertices), np.asarray(mesh.faces)


def plot_object(name: str, params: Any, path: str | os.PathLike) -> Path:
    """Draw object `name` (mm axes, one colour per part) and save a PNG atomically; return path."""
    built = build(name, params)
    info = built.info
    fig = plt.figure(figsize=(6, 6), dpi=100)
    ax = fig.add_subplot(projection="3d")
    colors = plt.get_cmap("tab20")
    every = []
    for k, part in enumerate(built.parts):
        v, f = surface(part)
        v = v * 1e3
        every.append(v)
        poly = Poly3DCollection(v[f], facecolor=colors(k % 20), edgecolor="k", linewidths=0.1,
                                alpha=0.9)
        ax.add_collection3d(poly)
    pts = np.concatenate(every)
    lo, hi = pts.min(0), pts.max(0)
    mid, half = (lo + hi) / 2, float(np.max(hi - lo)) / 2
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(max(0.0, mid[2] - half), max(0.0, mid[2] - half) + 2 * half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(f"{name}: {info.mass_kg * 1e3:.0f} g, phi_T = {info.phi_t:.3f}, "
                 f"{info.n_parts} parts", fontsize=10)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=out.parent, prefix=f".{out.stem}.", suffix=".png")
    os.close(fd)
    try:
        fig.savefig(tmp, format="png")
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    finally:
        plt.close(fig)
    return out
