"""Entanglement metrics: pure functions of filament geometry (ACN, local fields) and of contacts.

Modules: `acn` (average crossing number of polylines), `local_fields` (ACN and filament count
inside small spheres), `contacts` (classification of MuJoCo contacts), `curve_file` (reading
curve archives for the CLI and scripts).
"""
