"""Property: any scene inside the documented envelope runs without tripping the watchdog.

Hypothesis draws a few filaments (1-3, 6-20 mm apart, every contact effect on), a segment count, a
modulus, a coil radius and a timestep, each within the bounds `entangle_bench.stability` documents:
a timestep at most the measured envelope's, a coil no tighter than 3 filament radii, resolved at
most 2 rad per segment and reachable with at most 2 MPa. Each scene is one probe (task `probe/curl_in_air`:
pressure ramp and hold in air) through the runner, under the watchdog.
"""

import dataclasses
import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from entangle_bench import stability
from entangle_bench.gripper import GripperParams
from entangle_bench.studies.stability_map import probe
from entangle_bench.suite.probe import ProbeConfig

REF = stability.REFERENCE_FILAMENT
MAX_PRESSURE_PA = 2e6  # the largest pressure GripperParams accepts


@st.composite
def scenes(draw):
    """A scene inside the envelope (see module docstring)."""
    integrator = draw(st.sampled_from(stability.INTEGRATORS))
    n = draw(st.integers(8, 64))
    modulus = 10 ** draw(st.floats(math.log10(0.05e6), math.log10(10e6)))
    fil = dataclasses.replace(REF, youngs_modulus_pa=modulus, n_segments=n)
    tightest = max(
        stability.MIN_COIL_RADIUS_RATIO * REF.outer_radius_m,
        fil.segment_length_m / stability.MAX_TURN_PER_SEGMENT_RAD,
        1.0 / fil.curvature_per_m(MAX_PRESSURE_PA),
    )
    radius = 10 ** draw(st.floats(math.log10(tightest * 1.001), math.log10(0.1)))
    pressure = 172e3 * (1.0 / radius) / fil.curvature_per_m(172e3)
    count = draw(st.integers(1, 3))
    spacing = draw(st.floats(0.006, 0.02))
    diameter = 0.0 if count == 1 else spacing / math.sin(math.pi / count)
    gripper = GripperParams(
        filament=fil, ring_diameters_m=(diameter,), ring_counts=(count,), pressure_pa=pressure
    )
    numerics = stability.base_numerics(integrator)
    config = ProbeConfig(gripper=gripper, numerics=numerics, duration_s=0.5)
    limit = stability.stable_timestep_s(config)
    dt = limit * draw(st.floats(0.5, 1.0))
    config = dataclasses.replace(config, numerics=dataclasses.replace(numerics, timestep_s=dt))
    return config, draw(st.integers(0, 2**16))


@settings(
    max_examples=25, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(scenes())
def test_scenes_inside_the_envelope_are_stable(scene):
    config, seed = scene
    assert stability.envelope_warnings(config) == []
    result = probe(config, seed=seed)
    assert result.stable, (result.reason, result.time_s, config)
