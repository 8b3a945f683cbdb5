"""Contact material: MuJoCo's soft-contact depth law, the analytic answer a resting object must match, and the
filaments' own friction, checked in the contact table MuJoCo builds."""

import mujoco
import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.filament import FilamentParams
from entangle_bench.geoms import role_of
from entangle_bench.gripper import GripperParams
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


@pytest.mark.parametrize("filament_friction", [None, 2.5])
def test_filament_friction_applies_to_filament_pairs_only(filament_friction):
    """MuJoCo's own contact table: filament-filament contacts carry `filament_friction` (else `friction`);
    filament-object, filament-ground and object-ground contacts carry `friction` whatever it is."""
    gripper = GripperParams(
        filament=FilamentParams(length_m=0.1, n_segments=10), ring_diameters_m=(0.0017,), ring_counts=(3,),
        pressure_pa=0.0, hub_radius_m=0.005,
    )
    contact = ContactParams(friction=1.0, filament_friction=filament_friction)
    config = SceneConfig(gripper=gripper, object_name="sphere", contact=contact, numerics=Numerics(timestep_s=1e-3))
    scene = build_scene(config, hub_pos=(0.0, 0.0, 0.17))  # filament tips 30 mm into the sphere's top: they pile
    model, data = scene.model, mujoco.MjData(scene.model)
    seen: dict[tuple[str, ...], set[float]] = {}
    for _ in range(200):
        mujoco.mj_step(model, data)
        for c in data.contact[: data.ncon]:
            kind = tuple(sorted(role_of(model.geom(g).name)[0] for g in (c.geom1, c.geom2)))
            seen.setdefault(kind, set()).add(float(c.friction[0]))
    expected = 1.0 if filament_friction is None else filament_friction
    assert seen[("filament", "filament")] == {expected}
    assert seen[("filament", "object")] == seen[("ground", "object")] == {1.0}


def test_filament_friction_out_of_range_is_refused():
    with pytest.raises(ParameterError, match=r"contact.filament_friction = -1.0 is outside the allowed range \[0, 10"):
        ContactParams(filament_friction=-1.0)
