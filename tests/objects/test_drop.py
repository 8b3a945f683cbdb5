"""Every object dropped from 1 cm onto the ground comes to rest within 1 s and then stays put."""

import mujoco
import numpy as np
import pytest

from entangle_bench import objects
from entangle_bench.objects.geometry import hull_points

DT_S = 0.002


def _drop_scene(name: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    spec = mujoco.MjSpec()
    spec.option.timestep = DT_S
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    objects.add_object(spec, name, pos=(0.0, 0.0, 0.01))
    model = spec.compile()
    return model, mujoco.MjData(model)


@pytest.mark.parametrize("name", objects.names())
def test_drop_from_1_cm_comes_to_rest(name):
    model, data = _drop_scene(name)
    body = model.body("object").id
    pts = hull_points(objects.build(name).parts)  # points on the object's surface, body frame

    def world() -> np.ndarray:
        return pts @ data.xmat[body].reshape(3, 3).T + data.xpos[body]

    steps_1s = round(1.0 / DT_S)
    for _ in range(steps_1s):
        mujoco.mj_step(model, data)
    at_rest = world()
    speed = np.linalg.norm(data.qvel[:3]) + np.linalg.norm(data.qvel[3:]) * objects.object_info(
        name).radius_m
    assert speed < 2e-3, f"{name} still moving at {speed:.2g} m/s after 1 s"
    for _ in range(2 * steps_1s):
        mujoco.mj_step(model, data)
    drift = np.max(np.linalg.norm(world() - at_rest, axis=1))
    assert drift < 1e-3, f"{name} drifted {drift * 1e3:.2f} mm"
    # resting on the ground: the lowest surface point sits at z = 0 (up to contact penetration)
    assert world()[:, 2].min() == pytest.approx(0.0, abs=1e-3)
    assert data.ncon > 0
