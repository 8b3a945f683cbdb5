"""Stability tests provoke MuJoCo warnings on purpose: keep them out of stdout and the log."""

import pytest

pytestmark = pytest.mark.usefixtures("quiet_mujoco")
