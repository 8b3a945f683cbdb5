"""Stored reference data for tests, and the scripts that regenerate it."""
