"""Shared test settings: headless plotting."""

import os

import mujoco
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def quiet_mujoco():
    """Silence MuJoCo's warning printer (for tests that provoke warnings on purpose), then restore it."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)
    yield
    mujoco.set_mju_user_warning(previous)
