"""Contact material: MuJoCo's soft-contact depth law, the analytic answer a resting object must match."""

import mujoco
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.presets import Numerics
from entangle_bench.scene import ContactParams, SceneConfig, build_scene

G = 9.81


def _resting_depth(impedance: tuple[float, float], timeconst_s: float) -> float:
    """Depth (m) of the 10 cm sphere resting on the ground after 1.5 s (the filaments hang clear above it)."""
    contact = ContactParams(timeconst_s=timeconst_s, impedance=impedance)
    config = SceneConfig(object_name="sphere", contact=contact, numerics=Numerics(timestep_s=1e-3))
    scene = build_scene(config, hub_pos=(0.0, 0.0, 0.6))
    model, data = scene.model, mujoco.MjData(scene.model)
    for _ in range(1500):
        mujoco.mj_step(model, data)
    depths = [-data.contact.dist[i] for i in range(data.ncon)]
    assert len(depths) == 1  # the sphere on the ground, nothing else touching
    return depths[0]


@pytest.mark.parametrize("d", [0.9, 0.99])
def test_resting_depth_follows_the_impedance(d):
    """At rest the contact passes 1 - d of gravity: depth (1 - d) g timeconst^2 (dampratio 1, d constant)."""
    timeconst = 0.01
    assert _resting_depth((d, d), timeconst) == pytest.approx((1 - d) * G * timeconst**2, rel=0.02)


def test_impedance_out_of_range_is_refused():
    with pytest.raises(ParameterError, match="contact.impedance"):
        ContactParams(impedance=(0.99, 0.9))
    with pytest.raises(ParameterError, match="contact.impedance"):
        ContactParams(impedance=(0.9, 1.0))
