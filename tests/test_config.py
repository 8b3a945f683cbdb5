"""`--set a.b=value` overrides of frozen configuration dataclasses."""

from __future__ import annotations

import pytest

from entangle_bench.config import apply_overrides
from entangle_bench.errors import ParameterError
from entangle_bench.suite import resolve_config


def test_coupled_fields_change_together():
    # Either override alone would leave ring diameters and counts of unequal length (a ParameterError).
    config = resolve_config("eight_branch_tree", None, ["gripper.ring_diameters_m=0.0", "gripper.ring_counts=1"])
    assert config.gripper.ring_diameters_m == (0.0,)
    assert config.gripper.ring_counts == (1,)
    assert config.gripper.n_filaments == 1


def test_later_override_of_a_field_wins_and_types_are_checked():
    config = resolve_config("eight_branch_tree", None, ["contact.friction=1.5", "contact.friction=2"])
    assert config.contact.friction == 2.0
    with pytest.raises(ParameterError, match="contact.friction: expected float"):
        resolve_config("eight_branch_tree", None, ["contact.friction=grippy"])


def test_unknown_field_names_the_path_and_the_known_fields():
    with pytest.raises(ParameterError, match="unknown setting 'gripper.filament.youngs' in FilamentParams"):
        resolve_config("eight_branch_tree", None, ["gripper.filament.youngs=1"])
    with pytest.raises(ParameterError, match="must look like name.field=value"):
        apply_overrides(resolve_config("eight_branch_tree"), ["contact.friction"])
