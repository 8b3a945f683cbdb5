"""Pull-out metrics: peak force, toughness and release of a force-displacement curve, and their statistics.

The pull-out test of Becker et al. (PNAS 2022): the object is held by the frame of a testing machine and the
actuated gripper is pulled away from it while the force is recorded. The pull force F is the force the gripper
exerts on the object along the pull direction (the object's weight tared); x is the hub's displacement along
that direction from the start of the pull. From one curve:

* release: F stays below `release_force_n` over `release_distance_m` of travel, after the grasp carried at least
  that force once or while no filament touches the object (`ReleaseDetector`); the release displacement is where
  that last stretch below the threshold begins;
* result: `released` (a real peak, at least the engagement force, then release), `slid_off` (released without
  ever carrying the engagement force) or `held` (no release before the largest travel: toughness is then a
  lower bound);
* peak force: the largest F of the curve (N), and its displacement;
* entanglement toughness: the work of the pull force until release, the trapezoid integral of F dx (J).

Per condition, `pullout_table` gives the median, interquartile range and a seeded percentile-bootstrap 95 %
interval of the median (`scipy.stats.bootstrap`) of peak force and toughness over the scored trials (stable,
finished) beside the reference's measured values. Unstable trials are counted and never scored.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from entangle_bench.errors import ParameterError
from entangle_bench.filament import REFERENCE_PRESSURE_PA
from entangle_bench.results import FAILED, UNSTABLE

#: Entanglement toughness measured by Becker et al. (PNAS 2022) at 172 kPa, J, by the library's object: a 10 cm
#: sphere, a simple branched structure (the eight-branch tree) and a vertical 51 mm cylinder.
REFERENCE_TOUGHNESS_J: Mapping[str, float] = {"sphere": 0.010, "eight_branch_tree": 0.380, "cylinder_51": 0.770}

#: Largest grasp force they measured over all objects at 172 kPa, N.
REFERENCE_MAX_FORCE_N = 27.6

#: How a pull-out ends (`PullMetrics.result`); '' for a curve that ended before either.
PULL_RESULTS = ("released", "slid_off", "held")


class ReleaseDetector:
    """Online release test of a pull-out curve, fed one point at a time.

    Released once the pull force has stayed below `force_n` over `distance_m` of travel, provided the grasp has
    carried at least `force_n` before (it let go) or no filament has touched the object over that distance (it
    came free without load). The slack before the filaments tighten is neither.
    """

    def __init__(self, force_n: float, distance_m: float):
        self.force_n, self.distance_m = force_n, distance_m
        self.loaded = False
        """Whether the force has reached `force_n` at some point."""
        self.below_since_m: float | None = None
        """Displacement where the current stretch below the threshold began, m (None while above)."""
        self.free_since_m: float | None = None
        """Displacement since which no filament has touched the object, m (None while one does)."""

    def update(self, displacement_m: float, force_n: float, touching: bool) -> bool:
        """Add one point (m, N, whether a filament touches the object); whether the pull has released."""
        if force_n >= self.force_n:
            self.loaded, self.below_since_m = True, None
        elif self.below_since_m is None:
            self.below_since_m = displacement_m
        if touching:
            self.free_since_m = None
        elif self.free_since_m is None:
            self.free_since_m = displacement_m
        if self.below_since_m is None:
            return False
        reach = self.distance_m - 1e-12
        free = self.free_since_m is not None and displacement_m - self.free_since_m >= reach
        return displacement_m - self.below_since_m >= reach and (self.loaded or free)


@dataclass(frozen=True)
class PullMetrics:
    """What one force-displacement curve says (SI units)."""

    result: str
    """One of PULL_RESULTS, or '' if the curve ended before release or the largest travel."""
    peak_force_n: float
    """Largest pull force of the curve, N."""
    displacement_at_peak_m: float
    toughness_j: float
    """Trapezoid integral of F dx from the start to the release (to the end when held: a lower bound), J."""
    displacement_at_release_m: float
    """Where the force fell below the release threshold for good, m (NaN unless released or slid off)."""
    travel_m: float
    """Hub displacement at the last point of the curve, m."""
    second_peak_force_n: float = math.nan
    """Largest pull force of the second method's curve (`analyze_curve`'s `second_force_n`), N; NaN if none."""
    second_toughness_j: float = math.nan
    """The second method's F dx integral over the same span as `toughness_j`, J; NaN if none."""
    span_points: int = 0
    """Number of leading curve points `toughness_j` integrates (to the release; all of them otherwise)."""

    @property
    def toughness_is_lower_bound(self) -> bool:
        """Whether the grasp still held at the largest travel, so the toughness is only a lower bound."""
        return self.result == "held"


def analyze_curve(
    displacement_m: Sequence[float],
    force_n: Sequence[float],
    touching: Sequence[bool],
    *,
    release_force_n: float,
    release_distance_m: float,
    engage_force_n: float,
    max_travel_m: float,
    second_force_n: Sequence[float] | None = None,
) -> PullMetrics:
    """Release (`ReleaseDetector`), result, peak force and toughness of one curve.

    Per point: displacement (m, from 0), pull force (N), whether a filament touches the object. The release is
    decided on `force_n`; `second_force_n`, the same force by a second method (N), gets its own peak and its
    integral over the same span, so the two methods' toughness can be compared.
    """
    x = np.asarray(displacement_m, dtype=float)
    f = np.asarray(force_n, dtype=float)
    contact = np.asarray(touching, dtype=bool)
    second = f if second_force_n is None else np.asarray(second_force_n, dtype=float)
    if x.ndim != 1 or x.shape != f.shape or x.shape != contact.shape or x.shape != second.shape or len(x) == 0:
        raise ParameterError(
            f"a curve needs equal, non-empty 1-D displacement, force, contact (and second force), got {x.shape}, "
            f"{f.shape}, {contact.shape}, {second.shape}"
        )
    detector = ReleaseDetector(release_force_n, release_distance_m)
    end, release, start = len(x), math.nan, 0
    for k in range(len(x)):
        above = detector.below_since_m is None
        released = detector.update(x[k], f[k], bool(contact[k]))
        if above and detector.below_since_m is not None:
            start = k
        if released:
            end, release = start + 1, float(x[start])
            break
    peak = int(np.argmax(f))
    if not math.isnan(release):
        result = "released" if f[peak] >= engage_force_n else "slid_off"
    elif x[-1] >= max_travel_m - 1e-9:
        result = "held"
    else:
        result = ""
    with_second = second_force_n is not None
    return PullMetrics(
        result=result,
        peak_force_n=float(f[peak]),
        displacement_at_peak_m=float(x[peak]),
        toughness_j=float(np.trapezoid(f[:end], x[:end])) if result else math.nan,
        displacement_at_release_m=release,
        travel_m=float(x[-1]),
        second_peak_force_n=float(np.max(second)) if with_second else math.nan,
        second_toughness_j=float(np.trapezoid(second[:end], x[:end])) if with_second and result else math.nan,
        span_points=end,
    )


@dataclass(frozen=True)
class MedianInterval:
    """Median, quartiles and bootstrap interval of the median of n values (their units)."""

    n: int
    median: float
    q25: float
    q75: float
    ci_low: float
    ci_high: float


def median_interval(
    values: Sequence[float], *, confidence: float = 0.95, n_resamples: int = 9999, seed: int = 0
) -> MedianInterval:
    """Median, interquartile range and seeded percentile-bootstrap interval of the median of the finite values.

    NaN where undefined: everything for no values, the interval for a single value.
    """
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return MedianInterval(0, *([math.nan] * 5))
    q25, median, q75 = (float(v) for v in np.percentile(x, [25, 50, 75]))
    low = high = math.nan
    if len(x) > 1:
        ci = stats.bootstrap(
            (x,),
            np.median,
            confidence_level=confidence,
            n_resamples=n_resamples,
            method="percentile",
            rng=np.random.default_rng(seed),
        ).confidence_interval
        low, high = float(ci.low), float(ci.high)
    return MedianInterval(len(x), median, q25, q75, low, high)


def reference_toughness_j(object_name: str, pressure_pa: float) -> float:
    """The reference's measured toughness for this object at this pressure, J (NaN if it measured none)."""
    if not math.isclose(pressure_pa, REFERENCE_PRESSURE_PA):
        return math.nan
    return REFERENCE_TOUGHNESS_J.get(object_name, math.nan)


#: Row columns (name, unit suffix) that `pullout_table` summarizes: the weld's peak force and toughness, and the
#: same from the filament-object contact sum (the second method; absent in rows written before it: NaN).
SUMMARIZED = (("peak_force", "n"), ("toughness", "j"), ("contact_peak_force", "n"), ("contact_toughness", "j"))


def pullout_table(rows: pd.DataFrame, by: Sequence[str], seed: int = 0) -> pd.DataFrame:
    """Per condition: trial counts by result, median, IQR and bootstrap 95 % CI of peak force and toughness, by
    the weld and by the contact sum (`SUMMARIZED`; `contact_scored` counts the rows that have the latter).

    Needs columns `outcome`, `pull_result`, `peak_force_n`, `toughness_j`, `config.object_name` and
    `config.gripper.pressure_pa`. Scored trials are stable ones with a result in PULL_RESULTS; unstable and
    failed trials (not run: `runner.failed_row`) are counted and never scored. Held trials enter with their
    toughness as a lower bound (`held` counts them).
    The reference columns hold the reference's measured values for the condition's object at 172 kPa.
    """
    out = []
    for key, group in rows.groupby(list(by), sort=True, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        scored = group[~group["outcome"].isin([UNSTABLE, FAILED]) & group["pull_result"].isin(PULL_RESULTS)]
        entry = dict(zip(by, key)) | {
            "trials": len(group),
            "unstable": int((group["outcome"] == UNSTABLE).sum()),
            "failed": int((group["outcome"] == FAILED).sum()),
            "scored": len(scored),
        }
        entry |= {result: int((scored["pull_result"] == result).sum()) for result in PULL_RESULTS}
        for column, unit in SUMMARIZED:
            summary = median_interval(scored.get(f"{column}_{unit}", []), seed=seed)
            entry |= {
                f"{column}_median_{unit}": summary.median,
                f"{column}_q25_{unit}": summary.q25,
                f"{column}_q75_{unit}": summary.q75,
                f"{column}_ci95_low_{unit}": summary.ci_low,
                f"{column}_ci95_high_{unit}": summary.ci_high,
            }
            if column == "contact_toughness":  # how many scored rows have the contact sum (older rows lack it)
                entry["contact_scored"] = summary.n
        names = group["config.object_name"].unique()
        pressures = group["config.gripper.pressure_pa"].unique()
        single = len(names) == 1 and len(pressures) == 1
        entry["reference_toughness_j"] = reference_toughness_j(names[0], pressures[0]) if single else math.nan
        entry["reference_max_force_n"] = REFERENCE_MAX_FORCE_N
        out.append(entry)
    return pd.DataFrame(out)


def intervals_overlap(low_a: float, high_a: float, low_b: float, high_b: float) -> bool:
    """Whether two intervals share a point (False if either is undefined)."""
    if any(math.isnan(v) for v in (low_a, high_a, low_b, high_b)):
        return False
    return low_a <= high_b and low_b <= high_a


def rate_agreement(table: pd.DataFrame, group: str, speed: str) -> pd.DataFrame:
    """Slowest against fastest pull speed per group of a `pullout_table`: ratio, medians, whether the CIs overlap.

    `table` has one row per (group, speed); peak force and toughness agree when their bootstrap 95 % intervals of
    the median overlap.
    """
    out = []
    for name, sub in table.groupby(group, sort=True):
        sub = sub.sort_values(speed)
        slow, fast = sub.iloc[0], sub.iloc[-1]
        entry = {group: name, "speed_slow_m_s": slow[speed], "speed_fast_m_s": fast[speed]}
        entry["speed_ratio"] = fast[speed] / slow[speed]
        for column, unit in (("peak_force", "n"), ("toughness", "j")):
            bounds = [row[f"{column}_ci95_{end}_{unit}"] for row in (slow, fast) for end in ("low", "high")]
            entry |= {
                f"{column}_median_slow_{unit}": slow[f"{column}_median_{unit}"],
                f"{column}_median_fast_{unit}": fast[f"{column}_median_{unit}"],
                f"{column}_agrees": intervals_overlap(*bounds),
            }
        out.append(entry)
    return pd.DataFrame(out)


@dataclass(frozen=True, eq=False)
class CurvePoint:
    """One point of a pull-out curve, logged every control step of the pull (SI units, world frame)."""

    displacement_m: float
    """Hub displacement along the pull direction since the pull began, m."""
    pull_force_n: float
    """Force the gripper exerts on the object along the pull direction, from the holding weld, N."""
    contact_pull_force_n: float
    """The same from the sum of the filament-object contact forces (the independent second method), N."""
    ground_pinch_pull_force_n: float
    """The part of `contact_pull_force_n` through filament segments that also touch the ground, N."""
    force_n: np.ndarray
    """(3,) force the gripper exerts on the object, from the weld: -(weld force + weight), N."""
    contact_force_n: np.ndarray
    """(3,) sum of the filament-object contact forces on the object, N."""
    weld_force_n: np.ndarray
    """(3,) force the holding weld exerts on the object: the load cell's raw reading, N."""
    contacts: Mapping[str, int]
    """Active contacts by kind (`geoms.KINDS`)."""
    hub_work_j: float
    """Work the hub has done on the filament roots since the pull began, J."""
    damping_loss_j: float
    """Energy the joint dampers have dissipated since the pull began, J."""
    constraint_work_j: float
    """Work the constraint forces (contacts, weld) have done since the pull began, J (< 0: dissipated)."""
    mechanical_energy_j: float
    """Gravity, elastic and kinetic energy of everything but the hub, J."""

    def as_series(self) -> dict[str, float]:
        """Named numbers for the runner's series: vectors as `<name>.x|y|z`, counts as `contacts.<kind>`."""
        flat: dict[str, float] = {}
        for name, value in vars(self).items():
            if name == "contacts":
                flat |= {f"contacts.{kind}": float(count) for kind, count in value.items()}
            elif np.ndim(value) == 1:
                flat |= {f"{name}.{axis}": float(v) for axis, v in zip("xyz", value)}
            else:
                flat[name] = float(value)
        return flat
