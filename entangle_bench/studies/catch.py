"""How well do the coils catch the object? A screen of gripper variants at the start of the lift.

Over the calibration's tree trials, success follows how many contacts the filaments hold on the object when
the lift starts (the row's `actuated.contacts.filament-object`; `catch_outcome_table` tabulates it from any
rows). A calibration trial costs 5–18 minutes on the 2-core machine, and the approach, actuation and settle
before the lift are about 40 % of its simulated time, so `screen` runs only those, for each variant and
seed, under the trial's own watchdog, and returns the state the runner's `actuated` snapshot records plus the
number of filaments that touch the object and their normal force on it. It ranks variants before a 20-seed
run; it does not replace one.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pandas as pd
from dm_control.rl.control import PhysicsError

from entangle_bench.atomic import atomic_save_npz
from entangle_bench.errors import ParameterError
from entangle_bench.metrics.contacts import contact_summary
from entangle_bench.metrics.stats import wilson_interval
from entangle_bench.results import SCORED, SUCCESS
from entangle_bench.runner import state_path
from entangle_bench.studies.branching import run_until
from entangle_bench.suite import resolve_config
from entangle_bench.watchdog import Watchdog, WatchdogTripped

#: The snapshot (`BenchTask.SNAPSHOTS`) a screen stops at.
SNAPSHOT = "actuated"


def catch_at_lift(task: str, config: Any, seed: int, save_to: Path | None = None) -> dict[str, Any]:
    """One trial run to the start of its `actuated` snapshot's phase under the watchdog: the snapshot's metrics,
    `filaments_touching_object`, `object_normal_force_n` (N, filament–object normal forces summed), `unstable`
    (the watchdog's reason, or ''), `sim_time_s` and `wall_s`. With `save_to`, the snapshot's arrays (the
    runner's `states/<id>_actuated.npz`: centerlines, contacts, the object's parts) are saved there."""
    start = time.perf_counter()
    watch: list[Watchdog] = []

    def reached(env: Any) -> bool:
        physics = env.physics
        model, data = physics.model.ptr, physics.data.ptr
        if watch:
            watch[0].check(model, data)
        else:  # after the reset, as the runner makes it
            watch.append(Watchdog(model, data, env.task.watchdog_limits(), env.task.actuation_energy_j()))
        return env.task.phase(physics) == type(env.task).SNAPSHOTS[SNAPSHOT]

    row: dict[str, Any] = {"seed": seed, "unstable": ""}
    try:
        env, ended = run_until(task, config, seed, reached)
    except (WatchdogTripped, PhysicsError, mujoco.FatalError) as exc:  # unstable, as the runner counts it
        row.update(unstable=str(exc), sim_time_s=np.nan, wall_s=time.perf_counter() - start)
        return row
    physics = env.physics
    if ended:
        raise RuntimeError(f"{task} seed {seed} ended before its {SNAPSHOT!r} snapshot")
    snap = env.task.snapshot(physics)
    row.update({f"{SNAPSHOT}.{k}": v for k, v in snap.metrics.items()})
    if save_to is not None:
        atomic_save_npz(save_to, **snap.arrays)
    summary = contact_summary(physics.model.ptr, physics.data.ptr, physics.scene.geoms)
    on_object = summary.kinds == "filament-object"
    filament = physics.scene.geoms.filament[summary.geom_pairs[on_object]]
    row["filaments_touching_object"] = len(np.unique(filament[filament >= 0]))
    row["object_normal_force_n"] = float(summary.normal_forces_n[on_object].sum())
    row.update(sim_time_s=physics.time(), wall_s=time.perf_counter() - start)
    return row


def parse_variant(text: str) -> tuple[str, list[str]]:
    """A screen variant `NAME:a.b=value[,c.d=value]` as (name, overrides); a tuple value keeps its commas
    (`wide:gripper.ring_diameters_m=0.056,0.025`). ParameterError when the name or the colon is missing."""
    name, sep, settings = text.partition(":")
    if not name or not sep:
        raise ParameterError(f"--variant {text!r}: expected NAME:a.b=value[,c.d=value], "
                             "e.g. deep:phases.drape_depth_m=0.3")
    overrides: list[str] = []
    for item in (s for s in settings.split(",") if s):
        if "=" in item or not overrides:
            overrides.append(item)
        else:
            overrides[-1] += "," + item
    return name, overrides


def screen(task: str, preset: str, variants: Mapping[str, Sequence[str]], seeds: Sequence[int],
           overrides: Sequence[str] = (), state_dir: Path | None = None) -> pd.DataFrame:
    """`catch_at_lift` for every variant (name -> `a.b=value` overrides on top of `overrides`) and seed; one row
    each, with `variant`. Every configuration is resolved first, so a bad override fails before anything runs.
    With `state_dir`, each snapshot goes to `<state_dir>/<variant>_seed<seed>_actuated.npz`."""
    configs = {name: resolve_config(task, preset, [*overrides, *extra]) for name, extra in variants.items()}
    rows = [{"variant": name, **catch_at_lift(task, config, seed, None if state_dir is None
                                              else state_path(state_dir, f"{name}_seed{seed}", SNAPSHOT))}
            for name, config in configs.items() for seed in seeds]
    return pd.DataFrame(rows)


def screen_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One line per variant of `screen`'s rows (the first variant is the baseline): stable and run trials, means of
    the filament–object contacts (± standard deviation), self-contacts, filaments touching and their normal force
    on the object (N), the mean paired difference in contacts against the baseline on the seeds both kept stable,
    and the mean wall per trial (s). A variant whose every trial went unstable gets NaN means, not an error."""
    contacts, self_contacts = f"{SNAPSHOT}.contacts.filament-object", f"{SNAPSHOT}.contacts.filament-self"
    metrics = [contacts, self_contacts, "filaments_touching_object", "object_normal_force_n"]
    rows = rows.reindex(columns=[*rows.columns, *(m for m in metrics if m not in rows.columns)])
    stable = rows[rows["unstable"] == ""]
    variants = list(dict.fromkeys(rows["variant"]))
    base = stable[stable["variant"] == variants[0]].set_index("seed")[contacts]
    out = []
    for name in variants:
        mine, ran = stable[stable["variant"] == name], rows[rows["variant"] == name]
        diff = (mine.set_index("seed")[contacts] - base).dropna()
        out.append({"variant": name, "stable": len(mine), "run": len(ran),
                    "contacts_mean": mine[contacts].mean(), "contacts_std": mine[contacts].std(),
                    "self_contacts_mean": mine[self_contacts].mean(),
                    "filaments_touching_mean": mine["filaments_touching_object"].mean(),
                    "normal_force_mean_n": mine["object_normal_force_n"].mean(),
                    "paired_contacts_diff": diff.mean(), "paired_seeds": len(diff),
                    "wall_mean_s": ran["wall_s"].mean()})
    return pd.DataFrame(out)


def catch_outcome_table(rows: pd.DataFrame, edges: Sequence[int] = (0, 22, 30, 40)) -> pd.DataFrame:
    """Success of scored trials (`outcome` success or failure) by their filament–object contacts at the start of
    the lift, binned at `edges` (each bin [edge, next edge), the last one open): trials, successes, rate and
    its Wilson 95 % interval."""
    scored = rows[rows["outcome"].isin(SCORED)]
    contacts = scored[f"{SNAPSHOT}.contacts.filament-object"]
    out = []
    for low, high in zip(edges, [*edges[1:], np.inf]):
        group = scored[(contacts >= low) & (contacts < high)]
        n, k = len(group), int((group["outcome"] == SUCCESS).sum())
        ci = wilson_interval(k, n) if n else (np.nan, np.nan)
        label = f"{low}–{int(high) - 1}" if np.isfinite(high) else f"≥ {low}"
        out.append({"contacts": label, "trials": n, "successes": k, "rate": k / n if n else np.nan,
                    "ci95_low": ci[0], "ci95_high": ci[1]})
    return pd.DataFrame(out)
