"""entangle-bench: a MuJoCo benchmark harness for entanglement grasping with soft filaments."""

import os

# Headless by construction: the harness draws every picture with matplotlib and never opens an OpenGL
# context, so dm_control must not probe for a display (a user may still set MUJOCO_GL=egl/osmesa).
os.environ.setdefault("MUJOCO_GL", "disable")

__version__ = "0.1.0"
