"""Trial videos: one MP4 per trial, headless, from pip-installable parts only.

Frames are taken every `period_s` of simulated time (not every control step: a frame costs far more than a
step) by one of two backends, and encoded with the ffmpeg binary that `imageio-ffmpeg` ships (H.264):

- `mujoco`: MuJoCo's offscreen renderer (`mujoco.Renderer`), which needs an OpenGL context. The package sets
  MUJOCO_GL=disable unless the user chose otherwise (dm_control must never probe for a display), so this
  backend is tried only when MUJOCO_GL was set to `egl` or `osmesa` before Python started. Where the
  context cannot be made, `auto` falls back to matplotlib and says why.
- `matplotlib`: `viz.draw_scene` on an Agg canvas (filaments, object parts, contacts, ground); always works.

`TrialVideo.backend` and `.reason` say which backend ran and why; `.seconds_per_frame` what a frame cost.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import imageio_ffmpeg
import mujoco
import numpy as np

from entangle_bench.atomic import AtomicFile
from entangle_bench.config import check_choice, check_range
from entangle_bench.errors import ParameterError
from entangle_bench.metrics.contacts import contact_summary
from entangle_bench.viz import draw_scene, object_geometry, post_geometry

BACKENDS = ("auto", "mujoco", "matplotlib")
GL_BACKENDS = ("egl", "osmesa")


def _bounds_m(env: Any) -> np.ndarray:
    """(2, 3) box around the filaments and the object now, raised by the lift height (m)."""
    physics = env.physics
    parts = object_geometry(physics.model.ptr, physics.data.ptr, physics.scene.geoms.is_object)
    points = np.vstack([physics.centerlines().reshape(-1, 3)] + [p.position_m[None] for p in parts])
    lo, hi = points.min(axis=0), points.max(axis=0)
    hi[2] += getattr(getattr(env.task.config, "phases", None), "lift_height_m", 0.0)  # room for a lift
    pad = 0.1 * float(np.max(hi - lo))
    lo, hi = lo - pad, hi + pad
    lo[2] = 0.0
    return np.array([lo, hi])


def _caption(env: Any) -> str:
    physics, task = env.physics, env.task
    return f"t = {physics.time():5.2f} s   {task.phase(physics):8s}   p = {task.pressure_pa / 1e3:5.1f} kPa"


class _MatplotlibFrames:
    """Frames drawn with matplotlib's Agg canvas at a fixed view of the whole trial."""

    def __init__(self, env: Any, size: tuple[int, int]):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.figure = Figure(figsize=(size[0] / 100, size[1] / 100), dpi=100)
        FigureCanvasAgg(self.figure)
        self.ax = ax = self.figure.add_subplot(projection="3d")
        lo, hi = 1e3 * _bounds_m(env)
        middle, half = 0.5 * (lo + hi), np.maximum(0.5 * (hi - lo), 0.4 * (hi[2] - lo[2]))
        lo[:2], hi[:2] = middle[:2] - half[:2], middle[:2] + half[:2]  # a landscape view of a tall scene
        for axis, set_limits in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            set_limits(lo[axis], hi[axis])
        ax.set_box_aspect(hi - lo, zoom=1.1)  # equal scale, no empty cube around a tall scene
        ax.set(xlabel="x (mm)", ylabel="y (mm)", zlabel="z (mm)")
        ax.view_init(elev=15, azim=-60)
        ax.locator_params(nbins=4)

    def render(self, env: Any) -> np.ndarray:
        """The current state as an (h, w, 3) uint8 image."""
        physics, ax = env.physics, self.ax
        model, data, scene = physics.model.ptr, physics.data.ptr, physics.scene
        for artist in [*ax.lines, *ax.collections]:  # keep the axes: rebuilding ticks is half a frame's cost
            artist.remove()
        contacts = contact_summary(model, data, scene.geoms)
        parts = object_geometry(model, data, scene.geoms.is_object) + post_geometry(model, data, scene.geoms.is_ground)
        draw_scene(ax, physics.centerlines(), parts, (contacts.points, contacts.kinds))
        ax.set_title(_caption(env), fontsize=9, family="monospace")
        self.figure.canvas.draw()
        return np.asarray(self.figure.canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        """Nothing to release."""


class _MujocoFrames:
    """Frames from MuJoCo's offscreen OpenGL renderer, a free camera looking at the whole scene."""

    def __init__(self, env: Any, size: tuple[int, int]):
        model = env.physics.model.ptr
        # The offscreen buffer must hold the frame; this changes only the model's visual options.
        model.vis.global_.offwidth = max(model.vis.global_.offwidth, size[0])
        model.vis.global_.offheight = max(model.vis.global_.offheight, size[1])
        self.renderer = mujoco.Renderer(model, height=size[1], width=size[0])
        lo, hi = _bounds_m(env)
        self.camera = mujoco.MjvCamera()
        self.camera.lookat[:] = 0.5 * (lo + hi)
        self.camera.distance = 1.4 * float(np.max(hi - lo))
        self.camera.azimuth, self.camera.elevation = 120.0, -15.0

    def render(self, env: Any) -> np.ndarray:
        """The current state as an (h, w, 3) uint8 image."""
        self.renderer.update_scene(env.physics.data.ptr, self.camera)
        return self.renderer.render()

    def close(self) -> None:
        """Release the OpenGL context."""
        self.renderer.close()


class TrialVideo:
    """Writes one trial as an MP4: a frame every `period_s` of simulated time, played at `fps`.

    Observer protocol: `start(env)` after reset, `step(env)` after every control step, `finish(row, complete)`
    at the end (`complete=False` deletes the partial file). `fps` defaults to 1 / period_s (real time);
    `size` is (width, height) in pixels, even numbers; `backend` one of BACKENDS.
    """

    def __init__(self, path: str | os.PathLike, period_s: float = 0.1, fps: float | None = None,
                 size: tuple[int, int] = (640, 480), backend: str = "auto"):
        check_range("video period_s", period_s, 0.0, 10.0, low_open=True)
        check_choice("video backend", backend, list(BACKENDS))
        if fps is not None:
            check_range("video fps", fps, 0.0, 240.0, low_open=True)
        for name, value in zip(("width", "height"), size):
            if not isinstance(value, int) or value % 2 or not 16 <= value <= 4096:
                raise ParameterError(f"video {name} = {value!r} must be an even integer in [16, 4096]")
        self.path = Path(path)
        self.period_s, self.size, self.requested = period_s, size, backend
        self.fps = 1.0 / period_s if fps is None else fps
        self.backend, self.reason = "", ""
        self.frames, self.frame_seconds = 0, 0.0
        self._frames: _MatplotlibFrames | _MujocoFrames | None = None
        self._file: AtomicFile | None = None
        self._encoder: Any = None
        self._next_s = 0.0

    @property
    def seconds_per_frame(self) -> float:
        """Mean wall time (s) to draw and encode one frame."""
        return self.frame_seconds / self.frames if self.frames else float("nan")

    def _open_frames(self, env: Any) -> _MatplotlibFrames | _MujocoFrames:
        gl = os.environ.get("MUJOCO_GL", "").lower()
        if self.requested == "matplotlib" or (self.requested == "auto" and gl not in GL_BACKENDS):
            self.backend = "matplotlib"
            self.reason = "requested" if self.requested == "matplotlib" else f"MUJOCO_GL={gl or 'unset'}"
            return _MatplotlibFrames(env, self.size)
        try:
            frames = _MujocoFrames(env, self.size)
        except Exception as exc:  # no GL context: the GL stacks raise many unrelated types
            if self.requested == "mujoco":
                raise ParameterError(f"video backend 'mujoco' needs an OpenGL context (MUJOCO_GL={gl or 'unset'}; "
                                     f"allowed: {', '.join(GL_BACKENDS)}): {type(exc).__name__}: {exc}") from None
            self.backend, self.reason = "matplotlib", f"MuJoCo renderer unavailable ({type(exc).__name__}: {exc})"
            return _MatplotlibFrames(env, self.size)
        self.backend, self.reason = "mujoco", f"MUJOCO_GL={gl}"
        return frames

    def start(self, env: Any) -> None:
        """Choose the backend, open the encoder and write the first frame (call after env.reset())."""
        self._frames = self._open_frames(env)
        self._file = AtomicFile(self.path)
        self._encoder = imageio_ffmpeg.write_frames(str(self._file.tmp), self.size, fps=self.fps, codec="libx264",
                                                    macro_block_size=2, ffmpeg_log_level="error")
        self._encoder.send(None)
        self._next_s = env.physics.time()
        self.step(env)

    def step(self, env: Any) -> None:
        """Write a frame if a period of simulated time has passed since the last one."""
        t = env.physics.time()
        if t + 1e-12 < self._next_s:
            return
        self._next_s += self.period_s
        if self._next_s <= t:  # control steps longer than the frame period
            self._next_s = t + self.period_s
        begin = time.perf_counter()
        self._encoder.send(np.ascontiguousarray(self._frames.render(env)))
        self.frame_seconds += time.perf_counter() - begin
        self.frames += 1

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Close the encoder and the renderer; keep the MP4 (atomic rename) only if `complete`."""
        if self._frames is not None:
            self._frames.close()
            self._frames = None
        if self._encoder is not None:
            self._encoder.close()
            self._encoder = None
        if self._file is not None:
            self._file.close(keep=complete)
            self._file = None
