"""Trials you can watch: a Foxglove MCAP recording and an MP4, both driven as observers of a short real trial."""

import importlib.util
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import imageio_ffmpeg
import numpy as np
import pytest
from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from mcap.decoder import DecoderFactory as McapDecoderFactory
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from entangle_bench.errors import ParameterError
from entangle_bench.recording import TrialRecorder, read_recording
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config
from entangle_bench.suite.pullout import PullOut
from entangle_bench.suite.top_drape import TopDrape
from entangle_bench.video import TrialVideo

FRAME_PERIOD_S = 0.25
ROOT = Path(__file__).resolve().parents[1]


def _load_bench():
    spec = importlib.util.spec_from_file_location("bench_watch", ROOT / "scripts" / "bench_watch.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


BENCH = _load_bench()


class Probe:
    """Observer that keeps the physics state at every step the recorder recorded."""

    def __init__(self, recorder):
        self.recorder, self.states, self.finished = recorder, [], None

    def start(self, env):
        self.step(env)

    def step(self, env):
        if self.recorder.samples > len(self.states):
            pos, quat = env.physics.object_pose()
            self.states.append((env.physics.time(), env.physics.centerlines(), pos, quat))

    def finish(self, row, complete):
        self.finished = (row, complete)


def run_observed(task, observers, seed=0):
    """A short real trial of `task` driven by the benchmark's loop (the runner's calls in miniature)."""
    return BENCH.run(resolve_config(task, "fast", SHORT_SEQUENCE), observers, seed)


@pytest.fixture(scope="module")
def watched(tmp_path_factory):
    folder = tmp_path_factory.mktemp("watched")
    recorder = TrialRecorder(folder / "trial.mcap", period_s=0.1, metadata={"task": "eight_branch_tree"})
    video = TrialVideo(folder / "trial.mp4", period_s=FRAME_PERIOD_S, size=(320, 240))
    probe = Probe(recorder)
    env = run_observed("eight_branch_tree", [recorder, probe, video])
    return env, recorder, video, probe


class JsonDecoderFactory(McapDecoderFactory):
    def decoder_for(self, message_encoding, schema):
        return json.loads if message_encoding == "json" else None


def _messages(path):
    """(schema, channel, message, decoded) of every message, protobuf decoded from the schemas in the file."""
    factories = [DecoderFactory(), JsonDecoderFactory()]
    with open(path, "rb") as handle:
        return list(make_reader(handle, decoder_factories=factories).iter_decoded_messages())


def test_recording_has_foxglove_channels_schemas_and_one_message_per_recorded_step(watched):
    env, recorder, _, probe = watched
    messages = _messages(recorder.path)
    schemas = {channel.topic: (schema.name, schema.encoding, channel.message_encoding)
               for schema, channel, _, _ in messages}
    assert schemas == {
        "/scene/static": ("foxglove.SceneUpdate", "protobuf", "protobuf"),
        "/scene/filaments": ("foxglove.SceneUpdate", "protobuf", "protobuf"),
        "/tf": ("foxglove.FrameTransforms", "protobuf", "protobuf"),
        "/trial/metrics": ("entangle_bench.TrialMetrics", "jsonschema", "json"),
    }
    counts = {topic: sum(c.topic == topic for _, c, _, _ in messages) for topic in schemas}
    n = len(probe.states)
    assert n == recorder.samples and n >= env.physics.time() / 0.1
    assert counts == {"/scene/static": 1, "/scene/filaments": n, "/tf": n, "/trial/metrics": n}


def test_recorded_line_strips_and_frames_are_the_physics_state_at_that_step(watched):
    _, recorder, _, probe = watched
    messages = _messages(recorder.path)
    lines = [(m.log_time, SceneUpdate.FromString(m.data)) for _, c, m, _ in messages if c.topic == "/scene/filaments"]
    frames = [FrameTransforms.FromString(m.data) for _, c, m, _ in messages if c.topic == "/tf"]
    for (stamp, update), tf, (t, centerlines, pos, quat) in zip(lines, frames, probe.states, strict=True):
        assert stamp == round(t * 1e9)
        (entity,) = update.entities
        assert entity.frame_id == "world" and len(entity.lines) == len(centerlines)
        points = np.array([[[p.x, p.y, p.z] for p in line.points] for line in entity.lines])
        np.testing.assert_array_equal(points, centerlines)
        obj = {f.child_frame_id: f for f in tf.transforms}["object"]
        np.testing.assert_array_equal([obj.translation.x, obj.translation.y, obj.translation.z], pos)
        np.testing.assert_array_equal([obj.rotation.w, obj.rotation.x, obj.rotation.y, obj.rotation.z], quat)


def test_static_scene_holds_the_object_parts_and_the_ground(watched):
    env, recorder, _, _ = watched
    (static,) = [d for _, c, _, d in _messages(recorder.path) if c.topic == "/scene/static"]
    entities = {e.id: e for e in static.entities}
    tree = entities["object"]
    assert tree.frame_id == "object" and entities["ground"].frame_id == "world"
    # the reference tree: trunk and base disc are cylinders, 8 branches are capsules (cylinder + 2 spheres)
    assert (len(tree.cylinders), len(tree.spheres)) == (10, 16)
    assert len(entities["ground"].cylinders) == 0  # no post


def test_static_scene_draws_the_post_an_object_stands_on(tmp_path):
    env = PullOut.make_environment(resolve_config("pullout/cube", "fast", ["pull.post_height_m=0.2"]), 0)
    env.reset()
    recorder = TrialRecorder(tmp_path / "post.mcap")
    recorder.start(env)
    recorder.finish({}, complete=True)
    (static,) = [d for _, c, _, d in _messages(recorder.path) if c.topic == "/scene/static"]
    (post,) = {e.id: e for e in static.entities}["ground"].cylinders
    assert (post.pose.position.z, post.size.x, post.size.z) == pytest.approx((0.1, 0.01, 0.2))


def test_metrics_and_metadata_are_readable(watched):
    _, recorder, _, probe = watched
    with open(recorder.path, "rb") as handle:
        reader = make_reader(handle)
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
        metrics = [json.loads(m.data) for _, c, m in reader.iter_messages(topics=["/trial/metrics"])]
    assert metadata["trial"] == {"task": "eight_branch_tree"} and metadata["result"]["outcome"] == "failure"
    assert {m["phase"] for m in metrics} >= {"approach", "actuate", "hold"}
    assert max(m["pressure_pa"] for m in metrics) > 0 and "filament_object" in metrics[0]["contacts"]
    states = list(read_recording(recorder.path))
    assert len(states) == len(probe.states)
    np.testing.assert_array_equal(states[-1]["centerlines_m"], probe.states[-1][1])


def test_mesh_object_parts_are_triangle_lists(tmp_path):
    env = TopDrape.make_environment(resolve_config("dexnet_endstop_holder", "fast", SHORT_SEQUENCE), 0)
    env.reset()
    recorder = TrialRecorder(tmp_path / "mesh.mcap")
    recorder.start(env)
    recorder.finish({}, True)
    (static,) = [d for _, c, _, d in _messages(recorder.path) if c.topic == "/scene/static"]
    obj = {e.id: e for e in static.entities}["object"]
    model = env.physics.model.ptr
    assert len(obj.triangles) == model.nmesh
    assert sum(len(t.indices) for t in obj.triangles) == 3 * int(model.mesh_facenum.sum())


def test_an_incomplete_trial_leaves_no_file(tmp_path):
    env = TopDrape.make_environment(resolve_config("sphere", "fast", SHORT_SEQUENCE), 0)
    env.reset()
    recorder, video = TrialRecorder(tmp_path / "x.mcap"), TrialVideo(tmp_path / "x.mp4", size=(64, 48))
    for observer in (recorder, video):
        observer.start(env)
        observer.finish({}, False)
    assert list(tmp_path.iterdir()) == []


def test_video_is_a_valid_mp4_with_one_frame_per_period(watched):
    env, _, video, _ = watched
    reader = imageio_ffmpeg.read_frames(str(video.path))
    meta = next(reader)
    frames = list(reader)
    assert meta["size"] == (320, 240) and meta["fps"] == pytest.approx(1 / FRAME_PERIOD_S)
    assert len(frames) == video.frames == int(env.physics.time() / FRAME_PERIOD_S + 1e-6) + 1
    assert all(len(f) == 320 * 240 * 3 for f in frames)
    assert video.backend == "matplotlib" and "MUJOCO_GL" in video.reason
    print(f"\nvideo: {video.frames} frames, {video.seconds_per_frame * 1e3:.0f} ms per frame ({video.backend})")


def test_video_settings_are_checked():
    with pytest.raises(ParameterError, match="even integer"):
        TrialVideo("x.mp4", size=(641, 480))
    with pytest.raises(ParameterError, match="backend"):
        TrialVideo("x.mp4", backend="opengl")


GL_VIDEO = textwrap.dedent("""
    from tests.test_watch import run_observed
    from entangle_bench.video import TrialVideo
    video = TrialVideo({path!r}, period_s=1.0, size=(160, 120))
    run_observed("sphere", [video])
    print(video.backend, video.frames, "|", video.reason)
""")


def test_video_uses_mujoco_rendering_when_a_gl_context_can_be_made(tmp_path):
    """MUJOCO_GL=egl: MuJoCo's renderer where EGL works (GPU or Mesa), matplotlib with the reason otherwise."""
    path = tmp_path / "gl.mp4"
    env = dict(os.environ, MUJOCO_GL="egl")
    done = subprocess.run([sys.executable, "-c", GL_VIDEO.format(path=str(path))], env=env, capture_output=True,
                          text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    backend, frames, *_ = done.stdout.split()
    assert backend == "mujoco" or "MuJoCo renderer unavailable" in done.stdout
    assert len(list(imageio_ffmpeg.read_frames(str(path)))) - 1 == int(frames) >= 2


def test_run_record_and_video_write_the_files_of_each_trial_under_the_output_folder(tmp_path, capsys):
    from entangle_bench.cli import main
    from entangle_bench.results import TrialLog

    argv = ["run", "sphere", "--trials", "1", "--workers", "1", "--preset", "fast", "--out", str(tmp_path),
            "--no-progress", "--record", "--video", *[a for s in SHORT_SEQUENCE for a in ("--set", s)]]
    assert main(argv) == 0
    ids = {row["trial_id"] for row in TrialLog(tmp_path / "trials.jsonl").rows()}
    assert len(ids) == 1
    assert {p.stem for p in (tmp_path / "recordings").glob("*.mcap")} == ids
    assert {p.stem for p in (tmp_path / "videos").glob("*.mp4")} == ids
    for trial_id in ids:
        assert len(list(read_recording(tmp_path / "recordings" / f"{trial_id}.mcap"))) > 10
        assert len(list(imageio_ffmpeg.read_frames(str(tmp_path / "videos" / f"{trial_id}.mp4")))) > 10
    leftovers = [p for p in tmp_path.rglob("*") if ".tmp" in p.name]
    assert leftovers == []
