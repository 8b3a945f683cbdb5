"""Stability tests provoke MuJoCo warnings on purpose: keep them out of stdout and the log."""

import mujoco
import pytest


@pytest.fixture(autouse=True)
def quiet_mujoco():
    """Silence MuJoCo's warning printer for one test, then restore it."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)
    yield
    mujoco.set_mju_user_warning(previous)
