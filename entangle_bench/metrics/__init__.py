"""Metrics: pure functions of filament geometry (ACN, local fields), of contacts and of result tables.

Modules: `acn` (average crossing number of polylines), `local_fields` (ACN and filament count
inside small spheres), `contacts` (classification of MuJoCo contacts), `curve_file` (reading
curve archives for the CLI and scripts), `stats` (success rates with Wilson intervals), `pullout`
(peak force, toughness and release of pull-out curves; median, IQR and bootstrap intervals per condition).
"""
