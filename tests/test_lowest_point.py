"""The object's lowest point (`geoms.lowest_z`) against MuJoCo's own geom–plane distance (`mj_geomDistance`)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from entangle_bench.geoms import lowest_z
from entangle_bench.scene import SceneConfig, build_scene

#: One free body per geom type over a ground plane; the mesh is an irregular convex hexahedron.
XML = """
<mujoco>
  <asset>
    <mesh name="hull" vertex="0 0 0  0.04 0.01 0  0.01 0.05 0.002  0 0 0.03  0.03 0.02 0.045  -0.01 0.03 0.02"/>
  </asset>
  <worldbody>
    <geom name="ground" type="plane" size="1 1 0.01"/>
    <body name="sphere" pos="0 0 0.2"><freejoint/><geom type="sphere" size="0.05"/></body>
    <body name="capsule" pos="0.2 0 0.2"><freejoint/><geom type="capsule" size="0.01 0.04"/></body>
    <body name="cylinder" pos="0.4 0 0.2"><freejoint/><geom type="cylinder" size="0.019 0.05"/></body>
    <body name="box" pos="0.6 0 0.2"><freejoint/><geom type="box" size="0.01 0.02 0.03"/></body>
    <body name="mesh" pos="0.8 0 0.2"><freejoint/><geom type="mesh" mesh="hull"/></body>
    <body name="ellipsoid" pos="1 0 0.2"><freejoint/><geom type="ellipsoid" size="0.01 0.02 0.03"/></body>
  </worldbody>
</mujoco>
"""

EXACT = ("sphere", "capsule", "cylinder", "box", "mesh")


def _posed(seed: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The model with every body at a random orientation, its centre 0.1–0.3 m above the ground."""
    model = mujoco.MjModel.from_xml_string(XML)
    data = mujoco.MjData(model)
    rng = np.random.default_rng(seed)
    for body in range(1, model.nbody):
        adr = model.jnt_qposadr[model.body_jntadr[body]]
        quat = rng.normal(size=4)
        data.qpos[adr : adr + 7] = [*model.body_pos[body][:2], rng.uniform(0.1, 0.3), *(quat / np.linalg.norm(quat))]
    mujoco.mj_forward(model, data)
    return model, data


def _plane_distance(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> float:
    """Signed distance from geom to the ground plane by MuJoCo's collision functions, m."""
    return mujoco.mj_geomDistance(model, data, geom, 0, 10.0, None)


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("name", EXACT)
def test_lowest_point_equals_mujoco_plane_distance(name, seed):
    model, data = _posed(seed)
    geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)  # geom i sits in body i
    assert lowest_z(model, data, np.array([geom])) == pytest.approx(_plane_distance(model, data, geom), abs=1e-9)


def test_other_types_are_bounded_below():
    model, data = _posed(0)
    geom = model.ngeom - 1
    assert lowest_z(model, data, np.array([geom])) < _plane_distance(model, data, geom) - 1e-3


def test_a_rolled_ball_rests_on_the_ground():
    """The candidate's sphere rolled 136° (the calibration's sphere trials) still touches the ground at 0.

    A bounding-box bound would put its lowest point 50 mm × (1 − √2) ≈ 21 mm below the ground.
    """
    radius = 0.05
    for degrees in (0.0, 136.0):
        angle = np.radians(degrees)  # a roll about x: the ball's centre stays at (0, 0, radius)
        centre_offset = radius * np.array([0.0, -np.sin(angle), np.cos(angle)])  # R (0, 0, r)
        origin = np.array([0.0, 0.0, radius]) - centre_offset
        scene = build_scene(
            SceneConfig(object_name="sphere"),
            object_pos=tuple(origin),
            object_quat=(np.cos(angle / 2), np.sin(angle / 2), 0.0, 0.0),
        )
        data = mujoco.MjData(scene.model)
        mujoco.mj_forward(scene.model, data)
        assert data.xpos[scene.object_body][2] == pytest.approx(radius * (1 - np.cos(angle)))  # the origin "rose"
        ids = np.flatnonzero(scene.geoms.is_object)
        assert lowest_z(scene.model, data, ids) == pytest.approx(0.0, abs=1e-9), degrees
