"""Single-rod reference problems: case files, closed-form/BVP references and the PyElastica engine."""
