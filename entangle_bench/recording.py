"""Trial recordings as MCAP files in Foxglove's well-known schemas, so the Foxglove app shows a trial in 3D.

Channels (protobuf, schemas from Foxglove's published `foxglove-schemas-protobuf`, except the metrics):

- `/scene/static` `foxglove.SceneUpdate`, once at the start: the object's parts in frame `object` (spheres,
  cylinders, cubes; capsules as a cylinder and two spheres; convex meshes as triangle lists) and the ground
  in frame `world`.
- `/scene/filaments` `foxglove.SceneUpdate`, every recorded step: one line strip per filament centerline
  (world frame, m), as thick as the filament.
- `/tf` `foxglove.FrameTransforms`, every recorded step: `world` -> `hub` and `world` -> `object`.
- `/trial/metrics` JSON (schema `entangle_bench.TrialMetrics`), every recorded step: time (s), phase and its
  index, pressure (Pa), the object's lowest point (m) and contact counts by kind, for Foxglove's plot panel.

Log times are the simulated time in ns. A file is written under a temporary name and renamed when the trial
ends (`entangle_bench.atomic`); `read_recording` reads the states back.

Why this stack: the pure-Python `mcap` writer (already the file format), Foxglove's generated protobuf
classes for the schemas, and `mcap-protobuf-support` for the schema descriptors and generic decoding. It has
one writer per file and no process-wide state, so it works unchanged in worker processes. The Foxglove SDK
also writes MCAP, but through a process-global logging context designed for live streaming, and brings a
compiled extension the files do not need.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_protobuf.schema import build_file_descriptor_set

from entangle_bench.atomic import AtomicFile
from entangle_bench.config import check_range
from entangle_bench.errors import FileFormatError
from entangle_bench.metrics.contacts import KINDS
from entangle_bench.viz import OBJECT_COLOR, Part, in_frame, object_geometry, post_geometry

STATIC, FILAMENTS, TF, METRICS = "/scene/static", "/scene/filaments", "/tf", "/trial/metrics"
METRICS_SCHEMA = {
    "title": "entangle_bench.TrialMetrics",
    "type": "object",
    "properties": {
        "time_s": {"type": "number"},
        "phase": {"type": "string"},
        "phase_index": {"type": "integer"},
        "pressure_pa": {"type": "number"},
        "object_lowest_z_m": {"type": "number"},
        "contacts": {"type": "object", "properties": {k.replace("-", "_"): {"type": "integer"} for k in KINDS}},
    },
}
_FILAMENT_COLORS = ((0.12, 0.47, 0.71), (0.17, 0.63, 0.17), (0.58, 0.40, 0.74), (0.09, 0.75, 0.81),
                    (0.89, 0.47, 0.76), (0.50, 0.50, 0.50))
GROUND_HALF_SIZE_M = 0.5


def _color(rgb: Sequence[float], alpha: float = 1.0) -> Color:
    return Color(r=rgb[0], g=rgb[1], b=rgb[2], a=alpha)


def _pose(position_m: np.ndarray, rotation: np.ndarray) -> Pose:
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.asarray(rotation, float).ravel())
    return Pose(position=Vector3(x=position_m[0], y=position_m[1], z=position_m[2]),
                orientation=Quaternion(w=quat[0], x=quat[1], y=quat[2], z=quat[3]))


def _stamp(time_ns: int) -> Timestamp:
    return Timestamp(seconds=time_ns // 10**9, nanos=time_ns % 10**9)


def _add_part(entity: SceneEntity, part: Part) -> None:
    """One object part as Foxglove primitives (sizes are full extents, MuJoCo's are half)."""
    color = _color(OBJECT_COLOR)
    pose = _pose(part.position_m, part.rotation)
    r, h = float(part.size[0]), float(part.size[1])
    if part.kind in ("sphere", "ellipsoid"):
        radii = part.size if part.kind == "ellipsoid" else np.full(3, r)
        entity.spheres.add(pose=pose, size=Vector3(x=2 * radii[0], y=2 * radii[1], z=2 * radii[2]), color=color)
    elif part.kind in ("cylinder", "capsule"):
        entity.cylinders.add(pose=pose, size=Vector3(x=2 * r, y=2 * r, z=2 * h), bottom_scale=1.0, top_scale=1.0,
                             color=color)
        if part.kind == "capsule":
            for sign in (-1.0, 1.0):
                end = part.position_m + sign * h * part.rotation[:, 2]
                entity.spheres.add(pose=_pose(end, part.rotation), size=Vector3(x=2 * r, y=2 * r, z=2 * r),
                                   color=color)
    elif part.kind == "box":
        s = 2 * part.size
        entity.cubes.add(pose=pose, size=Vector3(x=s[0], y=s[1], z=s[2]), color=color)
    else:
        entity.triangles.add(pose=pose, color=color, points=[Point3(x=x, y=y, z=z) for x, y, z in part.vertices_m],
                             indices=part.faces.ravel().tolist())


class TrialRecorder:
    """Records one trial to an MCAP file at a fixed period (s) of simulated time: an observer of the runner.

    `start(env)` after reset opens the file (temporary name) and records the static scene and the first state;
    `step(env)` after every control step records the state once a period has passed; `finish(row, complete)`
    stores the outcome as metadata and renames the file into place, or deletes it when `complete` is False.
    Works for every gripper task (`suite.gripper_task`); a scene without an object records no object.
    """

    def __init__(self, path: str | os.PathLike, period_s: float = 0.05, metadata: dict[str, str] | None = None):
        check_range("recording period_s", period_s, 0.0, 10.0, low_open=True)
        self.path = Path(path)
        self.period_s = period_s
        self.metadata = dict(metadata or {})
        self.samples = 0
        self._file: AtomicFile | None = None
        self._handle: Any = None
        self._writer: Writer | None = None
        self._channels: dict[str, int] = {}
        self._next_s = 0.0
        self._phases: tuple[str, ...] = ()

    def _channel(self, topic: str, message_class: Any = None) -> int:
        if topic not in self._channels:
            if message_class is None:
                schema = self._writer.register_schema(METRICS_SCHEMA["title"], "jsonschema",
                                                      json.dumps(METRICS_SCHEMA).encode())
                self._channels[topic] = self._writer.register_channel(topic, "json", schema)
            else:
                schema = self._writer.register_schema(
                    message_class.DESCRIPTOR.full_name, "protobuf",
                    build_file_descriptor_set(message_class).SerializeToString())
                self._channels[topic] = self._writer.register_channel(topic, "protobuf", schema)
        return self._channels[topic]

    def _write(self, topic: str, time_ns: int, message: Any) -> None:
        if isinstance(message, dict):
            channel, data = self._channel(topic), json.dumps(message).encode()
        else:
            channel, data = self._channel(topic, type(message)), message.SerializeToString()
        self._writer.add_message(channel, time_ns, data, time_ns, self.samples)

    def _write_static(self, physics: Any, time_ns: int) -> None:
        """The object's parts in its body frame (if the scene has an object) and the ground (with the post the
        object may stand on), once."""
        model, data, scene = physics.model.ptr, physics.data.ptr, physics.scene
        entities = []
        body = scene.object_body
        if body >= 0:
            parts = in_frame(object_geometry(model, data, scene.geoms.is_object), data.xpos[body],
                             data.xmat[body].reshape(3, 3))
            obj = SceneEntity(timestamp=_stamp(time_ns), frame_id="object", id="object")
            for part in parts:
                _add_part(obj, part)
            entities.append(obj)
        ground = SceneEntity(timestamp=_stamp(time_ns), frame_id="world", id="ground")
        ground.cubes.add(pose=_pose(np.array([0.0, 0.0, -0.0005]), np.eye(3)),
                         size=Vector3(x=2 * GROUND_HALF_SIZE_M, y=2 * GROUND_HALF_SIZE_M, z=0.001),
                         color=_color((0.8, 0.8, 0.8), 0.6))
        for part in post_geometry(model, data, scene.geoms.is_ground):
            _add_part(ground, part)
        entities.append(ground)
        self._write(STATIC, time_ns, SceneUpdate(entities=entities))

    def _record(self, env: Any) -> None:
        """Write the filaments, the frames and the metrics of the current state."""
        physics, task = env.physics, env.task
        time_s = physics.time()
        self._next_s = time_s + self.period_s
        stamp = int(round(time_s * 1e9))
        thickness = 2 * physics.scene.config.gripper.filament.outer_radius_m
        lines = SceneEntity(timestamp=_stamp(stamp), frame_id="world", id="filaments")
        for k, curve in enumerate(physics.centerlines()):
            lines.lines.add(type=LinePrimitive.LINE_STRIP, pose=_pose(np.zeros(3), np.eye(3)), thickness=thickness,
                            scale_invariant=False, color=_color(_FILAMENT_COLORS[k % len(_FILAMENT_COLORS)]),
                            points=[Point3(x=x, y=y, z=z) for x, y, z in curve])
        self._write(FILAMENTS, stamp, SceneUpdate(entities=[lines]))
        hub = physics.hub_position()
        transforms = [FrameTransform(timestamp=_stamp(stamp), parent_frame_id="world", child_frame_id="hub",
                                     translation=Vector3(x=hub[0], y=hub[1], z=hub[2]), rotation=Quaternion(w=1.0))]
        has_object = physics.scene.object_body >= 0
        if has_object:
            pos, quat = physics.object_pose()
            transforms.append(FrameTransform(timestamp=_stamp(stamp), parent_frame_id="world", child_frame_id="object",
                                             translation=Vector3(x=pos[0], y=pos[1], z=pos[2]),
                                             rotation=Quaternion(w=quat[0], x=quat[1], y=quat[2], z=quat[3])))
        self._write(TF, stamp, FrameTransforms(transforms=transforms))
        phase = task.phase(physics)
        metrics = {
            "time_s": time_s,
            "phase": phase,
            "phase_index": self._phases.index(phase) if phase in self._phases else len(self._phases),
            "pressure_pa": task.pressure_pa,
            "contacts": {k.replace("-", "_"): n for k, n in physics.contact_counts().items()},
        }
        if has_object:
            metrics["object_lowest_z_m"] = physics.object_lowest_z()
        self._write(METRICS, stamp, metrics)
        self.samples += 1

    def start(self, env: Any) -> None:
        """Open the file and record the static scene and the initial state (call after env.reset())."""
        self._file = AtomicFile(self.path)
        self._handle = open(self._file.tmp, "wb")
        self._writer = Writer(self._handle)
        self._writer.start(profile="", library="entangle-bench")
        if self.metadata:
            self._writer.add_metadata("trial", self.metadata)
        self._phases = tuple(env.task.PHASES)
        self._write_static(env.physics, int(round(env.physics.time() * 1e9)))
        self._record(env)

    def step(self, env: Any) -> None:
        """Record the environment's state if a period of simulated time has passed since the last record."""
        if env.physics.time() + 1e-12 >= self._next_s:
            self._record(env)

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Store the outcome as metadata and close; keep the file (atomic rename) only if `complete`."""
        if self._writer is None:
            return
        if complete:
            keys = ("outcome", "failure_mode", "unstable_reason", "lift_clearance_m", "sim_time_s")
            self._writer.add_metadata("result", {k: str(row[k]) for k in keys if k in row})
        self._writer.finish()
        self._handle.close()
        self._file.close(keep=complete)
        self._writer = None


def read_recording(path: str | os.PathLike) -> Iterator[dict[str, Any]]:
    """Yield the recorded states in time order: the `/trial/metrics` fields plus `hub_position_m`,
    `object_position_m`, `object_quaternion` (wxyz) and `centerlines_m` (F, n + 1, 3), m."""
    states: dict[int, dict[str, Any]] = {}
    try:
        with open(path, "rb") as handle:
            for _, channel, message in make_reader(handle).iter_messages(topics=[FILAMENTS, TF, METRICS]):
                state = states.setdefault(message.log_time, {})
                if channel.topic == METRICS:
                    state.update(json.loads(message.data))
                elif channel.topic == TF:
                    for tf in FrameTransforms.FromString(message.data).transforms:
                        t, q = tf.translation, tf.rotation
                        state[f"{tf.child_frame_id}_position_m"] = np.array([t.x, t.y, t.z])
                        if tf.child_frame_id == "object":
                            state["object_quaternion"] = np.array([q.w, q.x, q.y, q.z])
                else:
                    (entity,) = SceneUpdate.FromString(message.data).entities
                    state["centerlines_m"] = np.array([[[p.x, p.y, p.z] for p in line.points]
                                                       for line in entity.lines])
    except (OSError, McapError) as exc:
        raise FileFormatError(f"{path}: cannot read the recording: {exc}") from None
    for stamp in sorted(states):
        yield states[stamp]
