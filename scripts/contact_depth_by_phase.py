"""Does a grasp lean on penetration? Deepest contact and deep-contact load share per phase of one trial.

Runs one top-drape trial (preset, `--set` overrides, seed) under an observer and prints, per task phase, the
deepest contact (mm, with the geom pair and time) and the share of the filament–object normal force that
contacts deeper than `--deep` (default: the filament radius) carry, summed over the control steps.
A hold carried by embedded filaments would show a large share in `hold`.

Usage: python scripts/contact_depth_by_phase.py [--task eight_branch_tree] [--preset balanced] [--seed 0]
                                               [--set a.b=v ...] [--deep 0.001]
"""

from __future__ import annotations

import argparse
import platform
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from entangle_bench.runner import simulate
from entangle_bench.studies.trial_args import add_trial_arguments, trial_from_arguments


@dataclass
class _Phase:
    deepest_m: float = 0.0
    where: str = ""
    deep_force_n: float = 0.0
    force_n: float = 0.0


class ContactDepth:
    """Observer: per phase, the deepest contact and the filament–object normal force by depth."""

    def __init__(self, deep_m: float) -> None:
        self.deep_m = deep_m
        self.phases: dict[str, _Phase] = {}
        self._names: list[str] = []

    def start(self, env: Any) -> None:
        model = env.physics.model.ptr
        self._names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)]

    def _kind(self, geom: int) -> str:
        name = self._names[geom]
        return "object" if name.startswith("object") else "filament" if "_g" in name else "other"

    def step(self, env: Any) -> None:
        physics = env.physics
        model, data = physics.model.ptr, physics.data.ptr
        load = self.phases.setdefault(env.task.phase(physics), _Phase())
        force = np.zeros(6)
        for i in range(data.ncon):
            contact = data.contact[i]
            depth = -float(contact.dist)
            if depth > load.deepest_m:
                load.deepest_m = depth
                load.where = f"{self._names[contact.geom1]} / {self._names[contact.geom2]} at {physics.time():.2f} s"
            if {self._kind(contact.geom1), self._kind(contact.geom2)} == {"object", "filament"}:
                mujoco.mj_contactForce(model, data, i, force)
                load.force_n += force[0]
                if depth > self.deep_m:
                    load.deep_force_n += force[0]

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to write: read `phases`."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_arguments(parser)
    parser.add_argument("--deep", type=float, default=None, help="depth counted as deep, m (default: filament radius)")
    args = parser.parse_args()
    task, config = trial_from_arguments(args)
    deep = args.deep if args.deep is not None else config.gripper.filament.outer_radius_m
    observer = ContactDepth(deep)
    row = simulate(task, config, args.seed, observers=[observer]).row
    print(f"machine: {platform.machine()} mujoco {mujoco.__version__}; {task} preset {args.preset} seed {args.seed} "
          f"{' '.join(args.overrides)}")
    print(f"outcome: {row['outcome']} {row.get('failure_mode') or row.get('unstable_reason') or ''}; "
          f"deepest after the grace time {1e3 * row['max_penetration_m']:.2f} mm")
    print(f"| phase | deepest contact (mm) | where | filament–object normal force deeper than {1e3 * deep:g} mm |")
    print("|---|---|---|---|")
    for name, load in observer.phases.items():
        share = load.deep_force_n / load.force_n if load.force_n > 0 else 0.0
        print(f"| {name} | {1e3 * load.deepest_m:.2f} | {load.where} | {100 * share:.1f} % |")


if __name__ == "__main__":
    main()
