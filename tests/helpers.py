"""Small builders shared by tests."""

from __future__ import annotations

import dataclasses

from entangle_bench import effects as fx
from entangle_bench.filament import FilamentParams
from entangle_bench.gripper import GripperParams
from entangle_bench.presets import Numerics
from entangle_bench.scene import Scene, SceneConfig, build_scene

#: Numerics for reaching static equilibrium quickly: implicit damping allows a long relaxation time.
STATICS = Numerics(timestep_s=1e-3, integrator="implicitfast", twist_armature_scale=100.0)


def single_filament_scene(
    effects: fx.Effects = fx.ISOLATED, numerics: Numerics = STATICS, **filament: object
) -> Scene:
    """One filament clamped at (0, 0, 0.5) hanging along -z, curling toward +x when actuated."""
    params = dataclasses.replace(FilamentParams(damping_time_s=0.2), **filament)
    gripper = GripperParams(
        filament=params, ring_diameters_m=(0.0,), ring_counts=(1,), bending_plane="fixed"
    )
    return build_scene(SceneConfig(gripper=gripper, effects=effects, numerics=numerics))
