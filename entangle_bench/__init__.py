"""entangle-bench: a MuJoCo benchmark harness for entanglement grasping with soft filaments."""

__version__ = "0.1.0"
