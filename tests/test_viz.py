"""Scene drawing: object parts from a compiled model, their surfaces, saved states and the entanglement figure."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from entangle_bench.atomic import atomic_save_npz
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config
from entangle_bench.suite.pullout import PullOut
from entangle_bench.suite.top_drape import TopDrape
from entangle_bench.viz import in_frame, object_geometry, pack, post_geometry, surface, unpack

ROOT = Path(__file__).resolve().parents[1]


def _env(task):
    env = TopDrape.make_environment(resolve_config(task, "fast", SHORT_SEQUENCE), 0)
    env.reset()
    return env


def _parts(task):
    physics = _env(task).physics
    return physics, object_geometry(physics.model.ptr, physics.data.ptr, physics.scene.geoms.is_object)


@pytest.mark.parametrize("task", ["eight_branch_tree", "cube", "tennis_ball", "dexnet_endstop_holder"])
def test_every_object_geom_becomes_a_part_whose_surface_lies_in_the_geom(task):
    physics, parts = _parts(task)
    model, data = physics.model.ptr, physics.data.ptr
    assert len(parts) == int(physics.scene.geoms.is_object.sum())
    for g, part in zip(np.flatnonzero(physics.scene.geoms.is_object), parts):
        vertices, _ = surface(part)
        # the drawn surface lies on or inside the geom MuJoCo collides with
        for point in vertices[:: max(1, len(vertices) // 20)]:
            local = part.rotation.T @ (point - data.geom_xpos[g])
            r, h = model.geom_size[g][:2]
            if part.kind == "sphere":
                assert np.linalg.norm(local) <= r + 1e-9
            elif part.kind == "capsule":
                assert np.linalg.norm(local - [0, 0, np.clip(local[2], -h, h)]) <= r + 1e-9
            elif part.kind == "cylinder":
                assert np.hypot(*local[:2]) <= r + 1e-9 and abs(local[2]) <= h + 1e-9
            elif part.kind == "box":
                assert np.all(np.abs(local) <= model.geom_size[g] + 1e-9)


def test_the_post_is_drawn_as_a_cylinder_from_the_ground_to_the_object():
    """A pull-out on a 0.2 m post of 5 mm radius: one cylinder part spanning z = 0 to 0.2 m under the object; none
    without a post, and never the ground plane."""
    for height in (0.0, 0.2):
        config = resolve_config("pullout/cube", "fast", [f"pull.post_height_m={height}"])
        env = PullOut.make_environment(config, 0)
        env.reset()
        physics = env.physics
        parts = post_geometry(physics.model.ptr, physics.data.ptr, physics.scene.geoms.is_ground)
        if height == 0.0:
            assert parts == []
            continue
        (post,) = parts
        assert post.kind == "cylinder" and np.allclose(post.size[:2], [0.005, 0.1])
        z = surface(post)[0][:, 2]
        assert z.min() == pytest.approx(0.0, abs=1e-9) and z.max() == pytest.approx(height)
        assert physics.object_lowest_z() == pytest.approx(height)


def test_parts_survive_an_npz_and_a_change_of_frame(tmp_path):
    physics, parts = _parts("dexnet_endstop_holder")
    np.savez(tmp_path / "p.npz", **pack(parts))
    with np.load(tmp_path / "p.npz") as arrays:
        back = unpack(arrays)
    assert [p.kind for p in back] == [p.kind for p in parts]
    for a, b in zip(parts, back):
        for field in ("size", "position_m", "rotation", "vertices_m", "faces"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    body = physics.scene.object_body
    pos, rot = physics.data.xpos[body], physics.data.xmat[body].reshape(3, 3)
    for local, world in zip(in_frame(parts, pos, rot), parts):
        np.testing.assert_allclose(surface(local)[0] @ rot.T + pos, surface(world)[0], atol=1e-12)
    assert unpack({}) == []


def test_saved_state_draws_the_object_in_the_entanglement_figure(tmp_path):
    env = _env("eight_branch_tree")
    physics = env.physics
    parts = object_geometry(physics.model.ptr, physics.data.ptr, physics.scene.geoms.is_object)
    state = tmp_path / "states" / "t_held.npz"
    snap = env.task.snapshot(physics)  # what the runner saves at a snapshot point
    assert "acn_total" in snap.metrics
    atomic_save_npz(state, **snap.arrays)
    with np.load(state) as arrays:
        assert len(unpack(arrays)) == len(parts) == 10
    out = tmp_path / "fig.png"
    done = subprocess.run([sys.executable, ROOT / "scripts" / "plot_entanglement.py", state, "--out", out],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert out.stat().st_size > 10_000
