"""Matplotlib 3D picture of an object's collision geoms, saved as PNG."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from entangle_bench.atomic import atomic_savefig  # noqa: E402
from entangle_bench.objects.registry import add_object  # noqa: E402
from entangle_bench.viz import draw_scene, object_geometry, set_equal_axes  # noqa: E402


def plot_object(name: str, params: Any, path: str | os.PathLike) -> Path:
    """Draw object `name` as MuJoCo compiles it (mm axes, one colour per part); save a PNG atomically."""
    spec = mujoco.MjSpec()
    info = add_object(spec, name, params)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    is_object = np.array([model.geom(g).name.startswith("object") for g in range(model.ngeom)])
    parts = object_geometry(model, data, is_object)
    fig = plt.figure(figsize=(6, 6), dpi=100)
    ax = fig.add_subplot(projection="3d")
    colors = plt.get_cmap("tab20")
    drawn = draw_scene(ax, parts=parts, ground=False, part_colors=[colors(k % 20) for k in range(len(parts))],
                       object_alpha=0.9)
    set_equal_axes(ax, drawn, floor=0.0)
    ax.set_title(f"{name}: {info.mass_kg * 1e3:.0f} g, phi_T = {info.phi_t:.3f}, "
                 f"{info.n_parts} parts", fontsize=10)
    try:
        return atomic_savefig(fig, path)
    finally:
        plt.close(fig)
