"""Shared test settings: headless plotting."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
