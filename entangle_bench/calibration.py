"""Grasp calibration: the reference observations a gripper model is fitted to, and the verdict of trial rows.

The fit is a search over gripper, contact, sequence and numerical settings judged on outcome statistics: a
candidate is the suite `calibration` (tree at zero offset and at 0.3 R_T, 10 cm sphere, 38 mm cylinder) plus
the suite `pullout` run with the same settings. `target_table` judges the rows of both against the reference
targets (a)–(d) (Becker et al., PNAS 2022); `parameter_table` lists the candidate's settings beside the package
defaults, with the source of each value and the physically defensible range where one is documented.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from entangle_bench.config import coerce_text
from entangle_bench.metrics.pullout import REFERENCE_TOUGHNESS_J
from entangle_bench.metrics.stats import wilson_interval
from entangle_bench.objects.registry import object_info
from entangle_bench.presets import PER_PHASE_OPTIONS
from entangle_bench.results import SCORED, SUCCESS, UNSTABLE
from entangle_bench.suite import TASKS, resolve_config
from entangle_bench.suite.pullout import PullSchedule
from entangle_bench.suite.top_drape import Schedule
from entangle_bench.suites import suite_path

#: Seeded trials per condition before a success-rate target is judged met or missed on its point estimate.
MIN_TRIALS = 20
#: (a) success rate of the eight-branch tree at zero offset.
TREE_RATE = 0.80
#: (b) the offset condition: this fraction of the tree's horizontal reach R_T; its rate within this of (a).
OFFSET_FRACTION = 0.3
OFFSET_TOLERANCE = 0.10
#: (d) each pull-out toughness within this factor of the reference's.
TOUGHNESS_FACTOR = 3.0

#: The suites a candidate is judged on: outcomes, then grasp strength with the same settings.
CALIBRATION_SUITE = "calibration"
PULLOUT_SUITE = "pullout"
TREE_TASK = "top_drape/eight_branch_tree"
CONTROL_TASKS = ("top_drape/sphere", "top_drape/cylinder_38")
TOUGHNESS_ORDER = ("sphere", "eight_branch_tree", "cylinder_51")
#: The pull-out's object welded in mid-air 0.3 m up, with no post (`pull.post_radius_m=0`): no ground within the
#: filaments' reach to pinch them and no fixture to lasso, so the toughness is the grip on the object alone.
MIDAIR_MOUNT = ("pull.post_height_m=0.3", "pull.post_radius_m=0")


@dataclass(frozen=True)
class Rate:
    """Success over the scored trials of one condition, with its Wilson 95 % interval."""

    successes: int
    scored: int
    unstable: int

    @property
    def value(self) -> float:
        return self.successes / self.scored if self.scored else math.nan

    @property
    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.scored)

    @property
    def enough(self) -> bool:
        return self.scored >= MIN_TRIALS

    def __str__(self) -> str:
        low, high = self.interval
        unstable = f" (+{self.unstable} unstable)" if self.unstable else ""
        if not self.scored:
            return f"no scored trials{unstable}"
        rate = f"{self.successes}/{self.scored} = {100 * self.value:.0f} %"
        return f"{rate} [{100 * low:.0f}, {100 * high:.0f}]{unstable}"


def condition_rows(rows: pd.DataFrame, task: str, offset_m: float = 0.0, tolerance_m: float = 5e-4) -> pd.DataFrame:
    """The rows of `task` at centering offset `offset_m` (m, within `tolerance_m`)."""
    return rows[(rows["task"] == task) & ((rows["config.offset_m"] - offset_m).abs() <= tolerance_m)]


def rate_of(rows: pd.DataFrame) -> Rate:
    """Success over the rows' scored trials, with their unstable count."""
    scored = rows[rows["outcome"].isin(SCORED)]
    return Rate(int((scored["outcome"] == SUCCESS).sum()), len(scored), int((rows["outcome"] == UNSTABLE).sum()))


def condition_rate(rows: pd.DataFrame, task: str, offset_m: float = 0.0, tolerance_m: float = 5e-4) -> Rate:
    """Success of `task` at centering offset `offset_m` (m, within `tolerance_m`) over the rows' scored trials."""
    return rate_of(condition_rows(rows, task, offset_m, tolerance_m))


def tree_offset_m() -> float:
    """The offset condition (b): `OFFSET_FRACTION` of the eight-branch tree's horizontal reach R_T, m."""
    return OFFSET_FRACTION * object_info("eight_branch_tree").radius_m


def _at_least(rate: Rate, target: float) -> str:
    low, high = rate.interval
    if rate.enough:
        return "met" if rate.value >= target else "missed"
    return "missed" if rate.scored and high < target else "open"


def _within(rate: Rate, base: Rate, tolerance: float) -> str:
    if rate.enough and base.enough:
        return "met" if abs(rate.value - base.value) <= tolerance else "missed"
    (low, high), (base_low, base_high) = rate.interval, base.interval
    separated = rate.scored and base.scored and (low - base_high > tolerance or base_low - high > tolerance)
    return "missed" if separated else "open"


def _below(rates: list[Rate], base: Rate) -> str:
    if any(r.scored and base.scored and r.interval[0] > base.interval[1] for r in rates):
        return "missed"
    if all(r.enough for r in rates) and base.enough:
        return "met" if all(r.value < base.value for r in rates) else "missed"
    return "open"


def _toughness(pullout: pd.DataFrame | None) -> tuple[str, str, str]:
    """(measured, ratios to the reference, status) of target (d) from a pull-out summary."""
    if pullout is None or pullout.empty:
        return "no pull-out rows", "", "open"
    median = dict(zip(pullout["config.object_name"], pullout["toughness_median_j"]))
    missing = [name for name in TOUGHNESS_ORDER if name not in median or not math.isfinite(median[name])]
    if missing:
        known = [f"{name} {1e3 * median[name]:.3g} mJ" for name in TOUGHNESS_ORDER if name not in missing]
        return ", ".join([*known, f"no toughness: {', '.join(missing)}"]), "", "open"
    values = [float(median[name]) for name in TOUGHNESS_ORDER]
    ratios = [v / REFERENCE_TOUGHNESS_J[name] for v, name in zip(values, TOUGHNESS_ORDER)]
    ordered = values[0] < values[1] < values[2]
    close = all(1 / TOUGHNESS_FACTOR <= r <= TOUGHNESS_FACTOR for r in ratios)
    measured = " < ".join(f"{name} {1e3 * v:.3g} mJ" for name, v in zip(TOUGHNESS_ORDER, values))
    if not ordered:
        measured = measured.replace(" < ", ", ")
    return measured, ", ".join(f"{r:.2g}" for r in ratios), "met" if ordered and close else "missed"


def target_table(trials: pd.DataFrame, pullout: pd.DataFrame | None = None,
                 midair: pd.DataFrame | None = None) -> pd.DataFrame:
    """Targets (a)–(d) of the calibration judged on trial rows and pull-out summaries (`pullout.csv`): the
    object on the ground (`pullout`) and, where given, welded in mid-air (`midair`, `MIDAIR_MOUNT`), each its own
    (d) row.

    Status: `met` or `missed` on ≥ `MIN_TRIALS` scored trials per condition; with fewer, `missed` only where the
    Wilson intervals already exclude the target, else `open`. (d) is judged on the median toughness per object.
    """
    tree = condition_rate(trials, TREE_TASK)
    offset = condition_rate(trials, TREE_TASK, tree_offset_m())
    controls = [condition_rate(trials, task) for task in CONTROL_TASKS]
    rows = [
        ("(a) tree, zero offset", f"success ≥ {100 * TREE_RATE:.0f} %", str(tree), _at_least(tree, TREE_RATE)),
        (f"(b) tree, offset {OFFSET_FRACTION:g} R_T ({1e3 * tree_offset_m():.1f} mm)",
         f"within {100 * OFFSET_TOLERANCE:.0f} points of (a)", str(offset), _within(offset, tree, OFFSET_TOLERANCE)),
        *[(f"(c) {task.split('/')[-1]}", "success below (a)", str(rate), _below([rate], tree))
          for task, rate in zip(CONTROL_TASKS, controls)],
    ]
    for where, summary in (("", pullout), (", object in mid-air", midair)):
        if where and summary is None:
            continue
        measured, ratios, status = _toughness(summary)
        reference = f"sphere < tree < cylinder_51, each within {TOUGHNESS_FACTOR:g}x of 10 / 380 / 770 mJ"
        rows.append((f"(d) pull-out toughness{where}", reference,
                     measured + (f" (ratios {ratios})" if ratios else ""), status))
    return pd.DataFrame(rows, columns=["target", "reference", "measured", "status"])


@dataclass(frozen=True)
class Parameter:
    """One calibrated setting: where its value comes from and, where documented, its defensible range."""

    path: str
    source: str
    """reference (the paper's device), physical estimate, fitted, or numerical (a solver choice)."""
    low: float | None = None
    high: float | None = None
    note: str = ""


#: The calibration's parameters, in table order.
PARAMETERS: tuple[Parameter, ...] = (
    Parameter("gripper.filament.length_m", "reference", 0.3, 0.3, "300 mm filaments"),
    Parameter("gripper.filament.outer_radius_m", "fitted", None, 0.3 / 400,
              "aspect ratio L / d ≥ 200 allows r ≤ 0.75 mm"),
    Parameter("gripper.filament.youngs_modulus_pa", "physical estimate", 0.5e6, 3e6, "silicone 0.5–3 MPa"),
    Parameter("gripper.filament.curvature_calibration", "fitted", note="sets the coil radius at 172 kPa"),
    Parameter("gripper.pressure_pa", "reference", 172e3, 172e3, "172 kPa"),
    Parameter("gripper.ring_diameters_m", "reference", note="8 on a 50 mm circle, 4 on a 25 mm circle"),
    Parameter("gripper.filament.joints", "numerical",
              note="hinges: twist GJ, within 2 % of L on every rod case at 40 segments; ball: twist EI, 3–28 % "
                   "of L off out of plane"),
    Parameter("gripper.filament.n_segments", "numerical"),
    Parameter("gripper.filament.twist_ratio", "fitted",
              note="rest twist / curvature: > 0 coils helically, as the reference's filaments do near full pressure"),
    Parameter("gripper.filament.stretch_at_clamp", "physical estimate",
              note="the tube's axial compliance L / (EA), lumped in one joint at the clamp"),
    Parameter("contact.friction", "physical estimate", 0.5, 2.0, "silicone on plastic 0.5–2"),
    Parameter("contact.timeconst_s", "fitted", note="stiff enough that filaments do not sink"),
    Parameter("contact.impedance", "fitted", note="MuJoCo solimp[0:2]: a contact passes 1 − d of the acceleration"),
    Parameter("effects.cone", "numerical"),
    Parameter("numerics.impratio", "numerical"),
    Parameter("numerics.impratio_phases", "numerical", note="impratio only in these phases (a wedge yields under it)"),
    Parameter("numerics.timestep_s", "numerical", note="inside the stability envelope and the coil limit"),
    Parameter("numerics.solver", "numerical"),
    Parameter("numerics.iterations", "numerical"),
    Parameter("numerics.noslip_iterations", "numerical"),
    Parameter("phases.drape_depth_m", "fitted"),
    Parameter("phases.lift_height_m", "fitted"),
    Parameter("phases.hold_time_s", "reference", 5.0, None, "the calibration holds ≥ 5 s"),
)


def _lookup(config: Any, path: str) -> Any:
    for part in path.split("."):
        config = getattr(config, part)
    return config


def parameter_table(candidate: Any, default: Any, parameters: tuple[Parameter, ...] = PARAMETERS) -> pd.DataFrame:
    """Each parameter's candidate value beside the default config's, its source and whether it lies inside its
    documented physical range (blank where none is documented)."""
    rows = []
    for p in parameters:
        value = _lookup(candidate, p.path)
        inside = ""
        if isinstance(value, int | float) and (p.low is not None or p.high is not None):
            inside = "yes" if (p.low is None or value >= p.low) and (p.high is None or value <= p.high) else "no"
        rows.append({"parameter": p.path, "value": value, "default": _lookup(default, p.path), "source": p.source,
                     "inside_physical_range": inside, "note": p.note})
    return pd.DataFrame(rows)


def candidate_overrides(suite: str = CALIBRATION_SUITE) -> list[str]:
    """The candidate's settings: the suite's `set`, then its first condition's, as `a.b=value` overrides."""
    data = tomllib.loads(suite_path(suite).read_text())
    settings = {**data.get("set", {}), **data["conditions"][0].get("set", {})}
    return [f"{path}={_override_text(value)}" for path, value in settings.items()]


def _override_text(value: Any) -> str:
    """A TOML value as `--set` text: lists comma-separated, booleans lower case."""
    if isinstance(value, list):
        return ",".join(_override_text(item) for item in value)
    return str(value).lower() if isinstance(value, bool) else str(value)


def pullout_overrides(overrides: list[str], task: str = "pullout_eight_branch_tree") -> list[str]:
    """The overrides that the pull-out task's config has (the gripper, contact, numerics and drape; not the lift).

    `numerics.noslip_phases` and `numerics.impratio_phases` name top-drape phases: the drape's own are kept, and
    the phases after the settle (lift, hold, release: the object carried) become the pull-out's (clamp, pull: the
    object pulled out).
    """
    config = TASKS.get(task).default_config()
    kept = []
    for override in overrides:
        path, _, value = override.partition("=")
        try:
            _lookup(config, path)
        except AttributeError:
            continue
        if path in {f"numerics.{field_name}" for field_name, _ in PER_PHASE_OPTIONS.values()}:
            override = f"{path}={','.join(_pullout_phases(coerce_text(value, tuple[str, ...], path)))}"
        kept.append(override)
    return kept


def run_commands(out: Path, trials: int, pullout_trials: int, workers: int, overrides: list[str]) -> list[list[str]]:
    """The `entangle-bench` argument lists that run a candidate (`overrides` on top of the calibration suite's):
    its calibration suite with `trials` seeds per condition into `out`, then its pull-out suite with
    `pullout_trials` seeds and the same gripper, contact and numerics into `out`/pullout (on the ground) and
    `out`/pullout_midair (`MIDAIR_MOUNT`).

    Both retry unstable trials at dt/2, also those a stopped run logged: the trials that break are not missing at
    random (at 0.25 ms every tree trial that broke with the object already up succeeded when retried), so scoring
    without them biases success and toughness low.
    """
    pull = pullout_overrides([*candidate_overrides(), *overrides])
    runs = [(CALIBRATION_SUITE, trials, out, overrides), (PULLOUT_SUITE, pullout_trials, out / "pullout", pull),
            (PULLOUT_SUITE, pullout_trials, out / "pullout_midair", [*pull, *MIDAIR_MOUNT])]
    return [["run", suite, "--trials", str(n), "--workers", str(workers), "--out", str(folder), "--retry-unstable",
             *(item for override in sets for item in ("--set", override))] for suite, n, folder, sets in runs]


def _pullout_phases(names: tuple[str, ...]) -> list[str]:
    """Top-drape phase names as the pull-out's: drape phases kept, the carrying phases -> clamp and pull."""
    phases = []
    for name in names:
        mapped = PullSchedule.AFTER_SETTLE if name in Schedule.AFTER_SETTLE else (name,)
        phases += [p for p in mapped if p not in phases]
    return phases


def candidate_parameters(overrides: list[str], preset: str | None = None) -> pd.DataFrame:
    """`parameter_table` of the tree under `overrides` against the tree's default config."""
    return parameter_table(resolve_config("eight_branch_tree", preset, overrides),
                           resolve_config("eight_branch_tree", preset))
