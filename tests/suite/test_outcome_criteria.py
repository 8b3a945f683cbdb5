"""The outcome's honesty criteria: a held object tilted past `max_tilt_deg` fails as `tilted`, unless it is a
ball; one carried by pinches beyond `max_pinched_support_w` of its weight fails as `pinched`."""

import dataclasses

import numpy as np
import pytest

from entangle_bench import objects
from entangle_bench.runner import simulate
from entangle_bench.suite import top_drape
from entangle_bench.suite.gripper_task import ScenePhysics

#: The weightless tree lift of the pinned rows (seed 2, fast): it succeeds.
WEIGHTLESS_LIFT = ("effects.gravity=false", "phases.drape_depth_m=0.1", "phases.lift_height_m=0.1")


def test_a_held_object_tilted_too_far_fails_as_tilted_unless_orientation_free(short_spec, monkeypatch):
    spec = short_spec("eight_branch_tree", seed=2, extra=WEIGHTLESS_LIFT)

    def row():
        return simulate(spec.task, spec.config, spec.seed).row

    upright = row()
    assert upright["outcome"] == "success" and upright["max_hold_tilt_deg"] < spec.config.max_tilt_deg
    monkeypatch.setattr(top_drape, "object_tilt_deg", lambda quat: 60.0)
    tipped = row()
    assert (tipped["outcome"], tipped["failure_mode"], tipped["max_hold_tilt_deg"]) == ("failure", "tilted", 60.0)
    monkeypatch.setattr(ScenePhysics, "object_orientation_free", lambda self: True)
    ball_like = row()
    assert (ball_like["outcome"], ball_like["max_hold_tilt_deg"]) == ("success", 60.0)


def test_balls_are_orientation_free_and_upright_objects_are_not():
    assert objects.object_info("sphere").orientation_free
    assert objects.object_info("tennis_ball").orientation_free
    for name in ("eight_branch_tree", "cylinder_38", "cylinder_51"):
        assert not objects.object_info(name).orientation_free, name


@pytest.mark.parametrize("pinch_w, outcome", [(0.4, ("success", "")), (0.6, ("failure", "pinched"))])
def test_a_hold_carried_by_a_pinch_fails_as_pinched(short_spec, monkeypatch, pinch_w, outcome):
    # The weightless lift, given a weight and an upward pinch force of `pinch_w` weights on every step.
    spec = short_spec("eight_branch_tree", seed=2, extra=WEIGHTLESS_LIFT)
    weight = np.array([0.0, 0.0, -0.3])
    measured = ScenePhysics.object_support

    def pinching(self):
        support = measured(self)
        return dataclasses.replace(support, pinched=support.pinched - pinch_w * weight)

    monkeypatch.setattr(ScenePhysics, "object_weight", lambda self: weight)
    monkeypatch.setattr(ScenePhysics, "object_support", pinching)
    row = simulate(spec.task, spec.config, spec.seed).row
    assert (row["outcome"], row["failure_mode"]) == outcome
    assert row["support.pinched_w"] == pytest.approx(pinch_w, abs=1e-9)
