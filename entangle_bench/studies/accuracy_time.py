"""Accuracy-time study: what each numerical setting costs and how much shape accuracy it buys.

Run it with `python scripts/accuracy_time_study.py [--smoke] [--out DIR] [--seeds N] [--skip-trial]`; this
module holds the study, the script only parses arguments and prints the report.

Three parts, all written under --out (default results/accuracy_time/):

1. Rod statics (rods.csv, kind "static"): every rod case in tasks/rod_cases/ with every filament
   representation (`entangle_bench.rods.representations`: harness ball chain, ball chain with series twist
   hinge, composite cable with the elasticity plugin, 1D flexcomp) and segment count; max and RMS centerline
   error / L against the analytic/BVP reference and against PyElastica. A static shape depends on the
   segments and the representation only (timestep, integrator and solver change how fast and whether the
   relaxation gets there, not where). Reference solutions are cached under --out/reference/.
2. Rod dynamics (rods.csv, kind "dynamic"): a 300 mm filament clamped horizontally and released under
   gravity with the harness's Kelvin-Voigt damping (0.02 s), 1 s; the tip trajectory is compared with a fine
   run (ball chain, 64 segments, dt 0.05 ms, implicitfast, no added armature). Sweeps segments, timestep,
   integrator, twist armature and representation; measures stability and CPU time per simulated second.
3. Top-drape trial (trial.csv): the full 12-filament trial (shortened hold) for a one-factor-at-a-time sweep
   around the balanced preset (segments, timestep, integrator, solver, iterations and tolerance, contact
   settings, armature) and the presets, a few seeds each, against a fine-resolution run of the same seeds:
   success, final object position and orientation, ACN and contact counts at the end of the hold, CPU and
   wall time per simulated second. Trials run through the runner (`runner.simulate`) with the watchdog, so an
   unstable trial means what it means everywhere; the end-of-hold state is the runner's `held` snapshot. A
   chaos floor (the fine run with 1 % larger initial perturbations)
   shows how far trials differ without any change of numerics.

Costs are CPU seconds (time.process_time) per simulated second: on an idle core that is the wall time, and
it is less disturbed by other processes on a shared machine than wall time (which is recorded as well).
pareto.png plots error against cost for rods and for the trial, with the presets marked; report.md holds
the markdown tables and the chosen presets. `smoke=True` runs a few seconds' worth of everything (no
PyElastica) for CI.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from dm_control.rl import control  # noqa: E402
from tqdm import tqdm  # noqa: E402

from entangle_bench import resources  # noqa: E402
from entangle_bench.atomic import atomic_savefig, atomic_write_text  # noqa: E402
from entangle_bench.errors import ParameterError  # noqa: E402
from entangle_bench.presets import PRESETS, Numerics, Preset  # noqa: E402
from entangle_bench.results import SUCCESS, UNSTABLE, atomic_write_csv, markdown  # noqa: E402
from entangle_bench.rods.case import RodCase, centerline_error, load_case  # noqa: E402
from entangle_bench.rods.comparison import (  # noqa: E402
    cached_result,
    case_error,
    reference_name,
    reference_result,
)
from entangle_bench.rods.references import has_reference  # noqa: E402
from entangle_bench.rods.representations import build_representation, solve_representation  # noqa: E402
from entangle_bench.runner import simulate  # noqa: E402
from entangle_bench.suite import resolve_config  # noqa: E402

CASES = resources.rod_cases_dir()
TASK = "top_drape/eight_branch_tree"
SWING_DAMPING_TIME_S = 0.02  # the harness filament's default Kelvin-Voigt time (FilamentParams)
TRIAL_OVERRIDES = ("phases.hold_time_s=0.5", "phases.release_time_s=0.1")
SMOKE_OVERRIDES = (
    "phases.drape_depth_m=0.02", "phases.ramp_time_s=0.2", "phases.settle_time_s=0.1",
    "phases.lift_height_m=0.01", "phases.hold_time_s=0.1", "phases.release_time_s=0.05",
)
SAMPLE_S = 0.01
#: Curl axis of the hinge joints while the swing filament is straight (its rest curl is about z).
BEND_AXIS = np.array([0.0, 0.0, 1.0])

#: Presets proposed from this study's results (results/accuracy_time/README.md), measured next to the
#: current PRESETS: fast and balanced move onto the rod Pareto front, balanced gets the segments the trial's
#: ACN needs, accurate drops the Newton solver and the 0.5 ms step that made a trial cost ~100x balanced.
PROPOSED = {
    "fast": Preset("fast", 12, Numerics(timestep_s=2e-3, iterations=10, tolerance=1e-4)),
    "balanced": Preset("balanced", 24, Numerics(timestep_s=2e-3)),
    "accurate": Preset("accurate", 32, Numerics(
        timestep_s=1e-3, integrator="implicitfast", iterations=100, tolerance=1e-8, twist_armature_scale=100.0,
    )),
}
CURL_RAMP_S = 0.5  # fraction of the run over which the curl_ramp test ramps its rest curvature


@dataclass(frozen=True)
class RodConfig:
    """One point of the rod dynamics sweep."""

    representation: str
    n_segments: int
    timestep_s: float
    integrator: str
    twist_armature_scale: float = 1000.0

    @property
    def label(self) -> str:
        """Short name."""
        return (
            f"{self.representation} n={self.n_segments} dt={self.timestep_s * 1e3:g}ms "
            f"{self.integrator} arm={self.twist_armature_scale:g}"
        )

    def numerics(self) -> Numerics:
        """Numerics of this point (solver settings irrelevant without constraints)."""
        return Numerics(
            timestep_s=self.timestep_s,
            integrator=self.integrator if self.integrator != "discrete" else "implicitfast",
            twist_armature_scale=self.twist_armature_scale,
        )


@dataclass(frozen=True)
class TrialConfig:
    """One point of the trial sweep: a preset plus overrides."""

    label: str
    preset: str
    overrides: tuple[str, ...] = ()


def preset_config(preset: Preset) -> RodConfig:
    """The rod-dynamics point of a preset."""
    n = preset.numerics
    return RodConfig("ball", preset.n_segments, n.timestep_s, n.integrator, n.twist_armature_scale)


def preset_overrides(preset: Preset) -> tuple[str, ...]:
    """Trial overrides that turn the default numerics (= balanced's) into `preset`'s."""
    default = Numerics()
    changed = [
        f"numerics.{f.name}={getattr(preset.numerics, f.name)}"
        for f in dataclasses.fields(Numerics)
        if getattr(preset.numerics, f.name) != getattr(default, f.name)
    ]
    return (f"gripper.filament.n_segments={preset.n_segments}", *changed)


# ----------------------------------------------------------------------------------------------- statics


def static_rows(
    cases: list[RodCase],
    plan: dict[str, list[int]],
    ref_dir: Path,
    elements: int | None,
) -> list[dict[str, Any]]:
    """Static error rows for each case, representation and segment count in `plan`."""
    rows = []
    jobs = [(c, r, n) for c in cases for r, ns in plan.items() for n in ns]
    refs = {}
    for case in tqdm(cases, desc="references", file=sys.stderr):
        # Stored PyElastica reference (multi-turn hanging coils) or the closed-form/BVP solution.
        exact = reference_result(case) if has_reference(case) else cached_result(case, "analytic", 0, ref_dir)
        pe = cached_result(case, "pyelastica", elements, ref_dir) if elements and not has_reference(case) else None
        refs[case.name] = (exact, pe)
    for case, rep, n in tqdm(jobs, desc="rod statics", file=sys.stderr):
        exact, pe = refs[case.name]
        row: dict[str, Any] = {
            "kind": "static",
            "case": case.name,
            "reference": reference_name(exact),
            "representation": rep,
            "n_segments": n,
        }
        try:
            start = time.process_time()
            result = solve_representation(case, rep, n)
            row["cpu_s"] = time.process_time() - start
        except ParameterError as exc:
            row["note"] = str(exc)[:120]
            rows.append(row)
            continue
        row["error_max"], row["error_rms"] = case_error(case, result.centerline, exact.centerline)
        if pe is not None:
            row["error_vs_pyelastica_max"] = centerline_error(result.centerline, pe.centerline, case.length)[0]
            row["pyelastica_vs_analytic_max"] = centerline_error(
                pe.centerline, exact.centerline, case.length
            )[0]
        row["sim_time_s"] = result.settings["sim_time_s"]
        rows.append(row)
    return rows


# ---------------------------------------------------------------------------------------------- dynamics


def swing_case() -> RodCase:
    """300 mm default filament (solid section) clamped horizontally in gravity, no rest curvature."""
    base = load_case(CASES / "soft_cantilever.json")
    return dataclasses.replace(base, name="swing", length=0.3, poisson_ratio=0.49)


def simulate_tip(
    case: RodCase, config: RodConfig, duration_s: float, ramp_s: float | None
) -> dict[str, Any]:
    """Tip samples every SAMPLE_S s from the straight rod, stability and CPU s per simulated s.

    With `ramp_s` the case's rest curvature is ramped from 0 to full over `ramp_s` s (updated every
    SAMPLE_S, like the trial's pressure ramp); without it the rod starts straight in its rest shape.
    """
    rod = build_representation(
        case, config.representation, config.n_segments, config.numerics(), SWING_DAMPING_TIME_S
    )
    model, data = rod.model, rod.data
    if config.integrator == "discrete":
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_DISCRETE
    ds = case.length / config.n_segments
    if ramp_s is not None:
        if rod.joints is None:
            raise ParameterError(f"{config.representation} cannot change its rest curvature at run time")
        rod.joints.set_rest(model, np.zeros(3), ds, BEND_AXIS)
        data.qpos[rod.joints.qpos] = model.qpos_spring[rod.joints.qpos]
        mujoco.mj_forward(model, data)
    per_sample = max(1, round(SAMPLE_S / model.opt.timestep))
    samples = [rod.vertices(data)[-1].copy()]
    stable = True
    start = time.process_time()
    for _ in range(round(duration_s / SAMPLE_S)):
        if ramp_s is not None:
            fraction = min(1.0, data.time / ramp_s)
            rod.joints.set_rest(model, fraction * case.darboux, ds, BEND_AXIS)
        mujoco.mj_step(model, data, per_sample)
        tip = rod.vertices(data)[-1]
        if not np.all(np.isfinite(tip)) or np.linalg.norm(tip - samples[0]) > 2 * case.length:
            stable = False
            break
        samples.append(tip.copy())
    cpu = time.process_time() - start
    warnings = sum(w.number for w in data.warning)
    return {
        "tips": np.array(samples),
        "stable": stable and warnings == 0,
        "cpu_per_sim_s": cpu / max(data.time, 1e-12),
        "nv": model.nv,
    }


def dynamic_rows(configs: list[RodConfig], reference: RodConfig, duration_s: float) -> list[dict[str, Any]]:
    """Swing and curl-ramp rows (error against `reference`, stability, cost) for every configuration."""
    tests = {
        "swing": (swing_case(), None),
        "curl_ramp": (load_case(CASES / "curl_hanging.json"), CURL_RAMP_S * duration_s),
    }
    rows = []
    for test, (case, ramp) in tests.items():
        ref = simulate_tip(case, reference, duration_s, ramp)
        for config in tqdm(configs + [reference], desc=f"rod dynamics ({test})", file=sys.stderr):
            label = ("reference: " if config == reference else "") + config.label
            row: dict[str, Any] = {"kind": "dynamic", "case": test, "label": label, **dataclasses.asdict(config)}
            try:
                out = ref if config == reference else simulate_tip(case, config, duration_s, ramp)
            except ParameterError as exc:
                rows.append({**row, "note": str(exc)[:120]})
                continue
            row.update(stable=out["stable"], cpu_per_sim_s=out["cpu_per_sim_s"], nv=out["nv"])
            if out["stable"]:
                k = min(len(out["tips"]), len(ref["tips"]))
                dist = np.linalg.norm(out["tips"][:k] - ref["tips"][:k], axis=1) / case.length
                row["error_max"], row["error_final"] = float(dist.max()), float(dist[-1])
            rows.append(row)
    return rows


# ------------------------------------------------------------------------------------------------- trial


class _HeldPose:
    """Observer: the object pose when the release starts (the runner's `held` snapshot point)."""

    def __init__(self) -> None:
        self.pose: tuple[np.ndarray, np.ndarray] | None = None

    def start(self, env: control.Environment) -> None:
        """Nothing to set up."""

    def step(self, env: control.Environment) -> None:
        """Keep the object pose at the first step of the release."""
        if self.pose is None and env.task.phase(env.physics) == "release":
            self.pose = env.physics.object_pose()

    def finish(self, row: dict[str, Any], complete: bool) -> None:
        """Nothing to close."""


def run_trial(config: TrialConfig, seed: int, extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """One top-drape trial through the runner: outcome, object pose and held-state metrics, CPU and wall s per sim s."""
    cfg = resolve_config(TASK, config.preset, (*TRIAL_OVERRIDES, *config.overrides, *extra))
    row: dict[str, Any] = {"label": config.label, "seed": seed, "preset": config.preset,
                           "overrides": " ".join(config.overrides),
                           "n_segments": cfg.gripper.filament.n_segments,
                           "timestep_s": cfg.numerics.timestep_s}
    held = _HeldPose()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    trial = simulate(TASK, cfg, seed, observers=[held]).row
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    if held.pose is not None and "held.acn_total" in trial:
        pos, quat = held.pose
        row.update(
            object_x=pos[0], object_y=pos[1], object_z=pos[2],
            object_qw=quat[0], object_qx=quat[1], object_qy=quat[2], object_qz=quat[3],
            acn=trial["held.acn_total"],
            contacts_filament_object=trial["held.contacts.filament-object"],
            contacts_filament_filament=trial["held.contacts.filament-filament"],
        )
    sim = max(trial["sim_time_s"], 1e-12)
    row.update(
        outcome=trial["outcome"],
        failure_mode=trial["failure_mode"],
        unstable_reason=trial["unstable_reason"],
        success=trial["outcome"] == SUCCESS,
        lift_clearance_m=trial["lift_clearance_m"],
        sim_time_s=sim,
        cpu_per_sim_s=cpu / sim,
        wall_per_sim_s=wall / sim,
    )
    return row


def quat_angle(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle (rad) between unit quaternions a and b."""
    return float(2.0 * np.arccos(np.clip(abs(np.sum(a * b, axis=-1)), 0.0, 1.0)))


def trial_deviation(rows: pd.DataFrame, fine: pd.DataFrame) -> pd.DataFrame:
    """Per-row deviation from the fine run of the same seed: object position (m), angle (rad), ACN, contacts."""
    fine = fine.set_index("seed")
    out = rows.copy()
    for name in ("position_dev_m", "angle_dev_rad", "acn_dev", "contacts_dev"):
        out[name] = np.nan
    for i, row in rows.iterrows():
        probe = "cost probe" in row["label"]  # a shortened trial: only its cost is comparable
        if probe or row["seed"] not in fine.index or row["outcome"] == UNSTABLE or pd.isna(row.get("object_x")):
            continue
        ref = fine.loc[row["seed"]]
        pos = np.array([row[f"object_{c}"] for c in "xyz"])
        ref_pos = np.array([ref[f"object_{c}"] for c in "xyz"])
        quat = np.array([row[f"object_q{c}"] for c in "wxyz"])
        ref_quat = np.array([ref[f"object_q{c}"] for c in "wxyz"])
        out.loc[i, "position_dev_m"] = float(np.linalg.norm(pos - ref_pos))
        out.loc[i, "angle_dev_rad"] = quat_angle(quat, ref_quat)
        out.loc[i, "acn_dev"] = row["acn"] - ref["acn"]
        out.loc[i, "contacts_dev"] = row["contacts_filament_object"] - ref["contacts_filament_object"]
    return out


def trial_configs(smoke: bool) -> tuple[list[TrialConfig], TrialConfig]:
    """The sweep around `balanced` plus the presets, and the fine reference configuration."""
    fine = TrialConfig(
        "fine n=32 dt=0.25ms implicitfast it=100 tol=1e-8 arm=10",
        "balanced",
        ("gripper.filament.n_segments=32", "numerics.timestep_s=0.00025", "numerics.integrator=implicitfast",
         "numerics.iterations=100", "numerics.tolerance=1e-8", "numerics.twist_armature_scale=10"),
    )
    if smoke:
        return (
            [TrialConfig("fast", "fast", SMOKE_OVERRIDES)],
            TrialConfig("balanced (smoke reference)", "balanced", SMOKE_OVERRIDES),
        )
    base = "balanced"
    sweep = [
        TrialConfig("fast", "fast"),
        TrialConfig("balanced", "balanced"),
        TrialConfig("n=12", base, ("gripper.filament.n_segments=12",)),
        TrialConfig("n=24", base, ("gripper.filament.n_segments=24",)),
        TrialConfig("n=32", base, ("gripper.filament.n_segments=32",)),
        TrialConfig("dt=4ms", base, ("numerics.timestep_s=0.004",)),
        TrialConfig("dt=1ms", base, ("numerics.timestep_s=0.001",)),
        TrialConfig("implicitfast", base, ("numerics.integrator=implicitfast",)),
        TrialConfig("newton", base, ("numerics.solver=newton",)),
        TrialConfig("pgs", base, ("numerics.solver=pgs",)),
        TrialConfig("it=10 tol=1e-4", base, ("numerics.iterations=10", "numerics.tolerance=1e-4")),
        TrialConfig("it=100 tol=1e-8", base, ("numerics.iterations=100", "numerics.tolerance=1e-8")),
        TrialConfig("impratio=10", base, ("numerics.impratio=10",)),
        TrialConfig("noslip=5", base, ("numerics.noslip_iterations=5",)),
        TrialConfig("contact tc=0.01s", base, ("contact.timeconst_s=0.01",)),
        TrialConfig("arm=100", base, ("numerics.twist_armature_scale=100",)),
        TrialConfig("n=24 dt=1ms implicitfast", base,
                    ("gripper.filament.n_segments=24", "numerics.timestep_s=0.001",
                     "numerics.integrator=implicitfast")),
    ]
    sweep += [TrialConfig(f"proposed {name}", base, preset_overrides(p)) for name, p in PROPOSED.items()]
    return sweep, fine


# -------------------------------------------------------------------------------------------- reporting


def pareto_mask(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """True where no other point has both lower-or-equal cost and error (and one strictly lower)."""
    mask = np.ones(len(cost), dtype=bool)
    for i in range(len(cost)):
        dominated = (cost <= cost[i]) & (error <= error[i]) & ((cost < cost[i]) | (error < error[i]))
        mask[i] = not np.any(dominated)
    return mask


def rod_summary(statics: pd.DataFrame, dynamics: pd.DataFrame) -> pd.DataFrame:
    """Per dynamic configuration: worst static error, dynamic errors and cost; the Pareto front.

    `static_error_max` is the worst over the cases the representation can hold, except
    curl_sideways_gravity (its own column): there the ball chain's isotropic twist spring, not the
    resolution, sets the error. `error` = max(static_error_max, curl_ramp_error_max) is the Pareto
    error; configurations that cannot be actuated (no curl_ramp result) or are unstable in either
    dynamic test are not on the front. Cost is the swing test's CPU s per simulated s.
    """
    ok = statics.dropna(subset=["error_max"])
    general = ok[ok["case"] != "curl_sideways_gravity"]
    worst = general.groupby(["representation", "n_segments"])["error_max"].max()
    sideways = ok[ok["case"] == "curl_sideways_gravity"].set_index(["representation", "n_segments"])
    dyn = dynamics[~dynamics["label"].str.startswith("reference")].set_index(["case", "label"])
    rows = []
    for label in dict.fromkeys(dyn.loc["swing"].index):
        swing = dyn.loc[("swing", label)]
        curl = dyn.loc[("curl_ramp", label)] if ("curl_ramp", label) in dyn.index else None
        if not bool(swing.get("stable", False)):
            continue
        key = (swing["representation"], swing["n_segments"])
        static = float(worst.get(key, np.nan))
        curl_error = float(curl["error_max"]) if curl is not None and bool(curl.get("stable")) else np.nan
        actuated_unstable = curl is not None and curl.get("stable") is False
        rows.append({
            "label": label,
            "representation": swing["representation"],
            "n_segments": swing["n_segments"],
            "timestep_s": swing["timestep_s"],
            "integrator": swing["integrator"],
            "twist_armature_scale": swing["twist_armature_scale"],
            "static_error_max": static,
            "curl_sideways_error": float(sideways["error_max"].get(key, np.nan)),
            "curl_ramp_error_max": curl_error,
            "swing_error_max": float(swing["error_max"]),
            "error": np.nan if np.isnan(curl_error) else max(static, curl_error),
            "cpu_per_sim_s": float(swing["cpu_per_sim_s"]),
            "actuated_stable": not actuated_unstable,
        })
    frame = pd.DataFrame(rows)
    if len(frame):
        eligible = frame["error"].notna() & frame["actuated_stable"]
        frame["pareto"] = False
        frame.loc[eligible, "pareto"] = pareto_mask(
            frame.loc[eligible, "cpu_per_sim_s"].to_numpy(), frame.loc[eligible, "error"].to_numpy()
        )
    return frame


def trial_summary(trials: pd.DataFrame) -> pd.DataFrame:
    """Per trial configuration: means over seeds."""
    grouped = trials.groupby("label", sort=False)
    summary = grouped.agg(
        seeds=("seed", "count"),
        n_segments=("n_segments", "first"),
        timestep_s=("timestep_s", "first"),
        success_rate=("success", "mean"),
        unstable=("outcome", lambda s: int((s == UNSTABLE).sum())),
        position_dev_mm=("position_dev_m", lambda s: 1e3 * s.mean()),
        angle_dev_deg=("angle_dev_rad", lambda s: math.degrees(s.mean())),
        acn_mean=("acn", "mean"),
        acn_dev_abs=("acn_dev", lambda s: s.abs().mean()),
        contacts_fo_mean=("contacts_filament_object", "mean"),
        contacts_dev_abs=("contacts_dev", lambda s: s.abs().mean()),
        cpu_per_sim_s=("cpu_per_sim_s", "mean"),
        wall_per_sim_s=("wall_per_sim_s", "mean"),
    ).reset_index()
    return summary


def plot_pareto(rods: pd.DataFrame, trial: pd.DataFrame, path: Path, presets: dict[str, str]) -> None:
    """Error vs CPU time per simulated second: rods (left) and the top-drape trial (right)."""
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
    ax = axes[0]
    for k, (rep, group) in enumerate(rods.groupby("representation")):
        actuated = group[group["error"].notna()]
        static_only = group[group["error"].isna()]
        if len(actuated):
            ax.scatter(actuated["cpu_per_sim_s"], actuated["error"], label=rep, s=18, alpha=0.7, color=f"C{k}")
        if len(static_only):
            ax.scatter(static_only["cpu_per_sim_s"], static_only["static_error_max"], s=22,
                       facecolors="none", edgecolors=f"C{k}",
                       label=f"{rep}: static error only (cannot be actuated)")
    front = rods[rods["pareto"]].sort_values("cpu_per_sim_s")
    ax.plot(front["cpu_per_sim_s"], front["error"], "k--", lw=1, label="Pareto front")
    for name, label in presets.items():
        hit = rods[rods["label"] == label]
        if len(hit):
            ax.scatter(hit["cpu_per_sim_s"], hit["error"], s=160, facecolors="none", edgecolors="red")
            ax.annotate(name, (hit["cpu_per_sim_s"].iloc[0], hit["error"].iloc[0]), color="red",
                        xytext=(6, 6), textcoords="offset points")
    ax.set(xscale="log", yscale="log", xlabel="CPU s per simulated s (one 300 mm rod, swing test)",
           ylabel="max(worst static error, curl-ramp error) / L",
           title="Rods: static cases (excl. curl_sideways) and actuated curl")
    ax.legend(fontsize=8)
    ax = axes[1]
    if len(trial):
        ok = trial.dropna(subset=["acn_dev_abs"])
        ok = ok[ok["acn_dev_abs"] > 0]
        ax.scatter(ok["cpu_per_sim_s"], ok["acn_dev_abs"], s=22)
        for _, row in ok.iterrows():
            color = "red" if row["label"] in presets else "0.3"
            ax.annotate(row["label"], (row["cpu_per_sim_s"], row["acn_dev_abs"]), fontsize=7,
                        color=color, xytext=(4, 3), textcoords="offset points")
        floor = trial[trial["label"].str.startswith("chaos floor")]
        if len(floor) and floor["acn_dev_abs"].iloc[0] > 0:
            ax.axhline(floor["acn_dev_abs"].iloc[0], color="0.5", ls=":", label="chaos floor (10 um offset)")
            ax.legend(fontsize=8)
        ax.set(xscale="log", yscale="log", xlabel="CPU s per simulated s (12-filament top-drape trial)",
               ylabel="|ACN - ACN of fine run| at end of hold (mean over seeds)",
               title="Top-drape trial against the fine-resolution run")
    fig.tight_layout()
    atomic_savefig(fig, path, dpi=120)
    plt.close(fig)


def preset_table(rods: pd.DataFrame, trial: pd.DataFrame) -> pd.DataFrame:
    """Current and proposed presets side by side: rod errors and cost, trial cost and deviations."""
    rows = []
    for name in PRESETS:
        for kind, preset in (("current", PRESETS[name]), ("proposed", PROPOSED[name])):
            label = preset_config(preset).label
            rod = rods[rods["label"] == label]
            trial_label = name if kind == "current" else f"proposed {name}"
            if kind == "current" and name == "accurate":
                trial_label = "accurate (current; cost probe, 1 s trial)"
            tri = trial[trial["label"] == trial_label] if len(trial) else trial
            row = {"preset": f"{name} ({kind})", "rod config": label}
            for column in ("static_error_max", "curl_ramp_error_max", "curl_sideways_error", "swing_error_max",
                           "cpu_per_sim_s"):
                row[f"rod {column}"] = float(rod[column].iloc[0]) if len(rod) else np.nan
            for column in ("cpu_per_sim_s", "acn_dev_abs", "position_dev_mm", "success_rate"):
                row[f"trial {column}"] = float(tri[column].iloc[0]) if len(tri) else np.nan
            rows.append(row)
    return pd.DataFrame(rows)


# -------------------------------------------------------------------------------------------------- main


def rod_plan(smoke: bool) -> tuple[list[RodCase], dict[str, list[int]], list[RodConfig], RodConfig, float]:
    """Cases, static plan, dynamic configurations, dynamic reference and swing duration (s)."""
    cases = [load_case(p) for p in sorted(CASES.glob("*.json"))]
    if smoke:
        cases = [c for c in cases if c.name in ("soft_cantilever", "arc_zero_gravity")]
        plan = {"hinges": [8], "cable": [8], "ball": [8], "flex1d": [8]}
        configs = [RodConfig("ball", 8, 2e-3, "implicitfast"), RodConfig("flex1d", 8, 1e-3, "discrete")]
        return cases, plan, configs, RodConfig("ball", 16, 5e-4, "implicitfast", 1.0), 0.1
    segments = [8, 12, 16, 24, 32, 40]
    plan = {"hinges": segments, "ball": segments, "cable": segments, "flex1d": [8, 12, 16, 24]}
    configs = []
    for n in segments:
        for dt in (4e-3, 2e-3, 1e-3, 5e-4):
            for integrator in ("euler", "implicitfast"):
                configs.append(RodConfig("ball", n, dt, integrator))
    for scale in (1.0, 10.0, 100.0):
        for n, dt in ((16, 2e-3), (24, 1e-3), (32, 1e-3)):
            for integrator in ("euler", "implicitfast"):
                configs.append(RodConfig("ball", n, dt, integrator, scale))
    for rep in ("hinges", "cable"):
        for n in (12, 16, 24, 32):
            for dt in (2e-3, 1e-3):
                configs.append(RodConfig(rep, n, dt, "implicitfast"))
    for n in (12, 16, 24, 32):
        for dt in (2e-3, 1e-3):
            configs.append(RodConfig("flex1d", n, dt, "discrete"))
    configs += [preset_config(p) for p in (*PRESETS.values(), *PROPOSED.values())]
    configs = list(dict.fromkeys(configs))
    return cases, plan, configs, RodConfig("ball", 64, 5e-5, "implicitfast", 1.0), 1.0


def write_outputs(
    out: Path, statics: pd.DataFrame, dynamics: pd.DataFrame, rods: pd.DataFrame, trial: pd.DataFrame,
    seconds: float,
) -> str:
    """Write pareto.png, presets.csv and report.md (markdown tables); return the report."""
    presets = {name: preset_config(p).label for name, p in PRESETS.items()}
    presets.update({f"proposed {name}": preset_config(p).label for name, p in PROPOSED.items()})
    plot_pareto(rods, trial, out / "pareto.png", presets)
    report = ["## Rod statics: max error / L against the analytic/BVP reference", ""]
    table = statics.pivot_table(index=["representation", "n_segments"], columns="case", values="error_max")
    report += [markdown(table.reset_index()), ""]
    report += ["## Rod dynamics and cost (Pareto points marked)", ""]
    if len(rods):
        shown = rods.sort_values("cpu_per_sim_s")[
            ["label", "static_error_max", "curl_sideways_error", "curl_ramp_error_max", "swing_error_max",
             "cpu_per_sim_s", "pareto"]
        ]
        report += [markdown(shown), ""]
    unstable = dynamics[dynamics["stable"].eq(False)] if "stable" in dynamics else dynamics.iloc[:0]
    if len(unstable):
        listed = "; ".join(f"{row.case}: {row.label}" for row in unstable.itertuples())
        report += ["Unstable dynamic runs: " + listed, ""]
    if len(trial):
        report += ["## Top-drape trial against the fine run (means over seeds)", "", markdown(trial), ""]
    if len(rods):
        presets_frame = preset_table(rods, trial)
        atomic_write_csv(presets_frame, out / "presets.csv")
        report += ["## Presets: current and proposed", "", markdown(presets_frame), ""]
    report += [f"total time {seconds:.0f} s"]
    text = "\n".join(report)
    atomic_write_text(out / "report.md", text + "\n")
    return text


def run_study(
    out: Path, smoke: bool = False, seeds: int | None = None, elements: int = 50, skip_trial: bool = False
) -> str:
    """Run the study and write its tables and plot under `out`; return the report (markdown).

    `seeds`: trial seeds per configuration (default 3, smoke 1); `elements`: PyElastica reference elements.
    """
    seeds = seeds or (1 if smoke else 3)
    started = time.perf_counter()

    cases, plan, configs, reference, duration = rod_plan(smoke)
    statics = pd.DataFrame(static_rows(cases, plan, out / "reference", None if smoke else elements))
    dynamics = pd.DataFrame(dynamic_rows(configs, reference, duration))
    atomic_write_csv(pd.concat([statics, dynamics], ignore_index=True), out / "rods.csv")
    rods = rod_summary(statics, dynamics)
    atomic_write_csv(rods, out / "rods_summary.csv")

    trial = pd.DataFrame()
    if not skip_trial:
        sweep, fine = trial_configs(smoke)
        rows = []
        jobs = [(c, s, ()) for c in [fine, *sweep] for s in range(seeds)]
        if not smoke:
            floor = TrialConfig("chaos floor (fine, hub offset 10 um)", fine.preset, fine.overrides)
            jobs += [(floor, s, ("offset_m=0.00001",)) for s in range(seeds)]
            probe = TrialConfig("accurate (current; cost probe, 1 s trial)", "accurate", SMOKE_OVERRIDES)
            jobs += [(probe, 0, ())]
        for config, seed, extra in tqdm(jobs, desc="trials", file=sys.stderr):
            rows.append(run_trial(config, seed, extra))
        raw = pd.DataFrame(rows)
        raw = trial_deviation(raw, raw[raw["label"] == fine.label])
        atomic_write_csv(raw, out / "trial.csv")
        trial = trial_summary(raw)
        atomic_write_csv(trial, out / "trial_summary.csv")

    return write_outputs(out, statics, dynamics, rods, trial, time.perf_counter() - started)
