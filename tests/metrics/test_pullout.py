"""Pull-out metrics: release, result, peak and toughness of known curves; median, IQR, bootstrap; the table."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from entangle_bench.errors import ParameterError
from entangle_bench.geoms import KINDS
from entangle_bench.metrics.pullout import (
    REFERENCE_MAX_FORCE_N,
    CurvePoint,
    analyze_curve,
    intervals_overlap,
    median_interval,
    pullout_table,
    rate_agreement,
)

STEP_M = 1e-4
CRITERIA = dict(release_force_n=0.002, release_distance_m=0.01, engage_force_n=0.05, max_travel_m=0.3)


def triangle(peak_n: float, half_width_m: float, slack_m: float = 0.0, tail_m: float = 0.03):
    """A curve with `slack_m` of zero force in contact, a triangle of height `peak_n`, then zero force, free."""
    x = np.arange(0.0, slack_m + 2 * half_width_m + tail_m, STEP_M)
    u = x - slack_m
    force = np.clip(peak_n * (1.0 - np.abs(u - half_width_m) / half_width_m), 0.0, None)
    touching = x < slack_m + 2 * half_width_m
    return x, force, touching


def test_triangle_releases_after_its_peak_with_the_area_as_toughness():
    x, f, touching = triangle(0.5, 0.02)
    m = analyze_curve(x, f, touching, **CRITERIA)
    assert m.result == "released" and not m.toughness_is_lower_bound
    assert m.peak_force_n == pytest.approx(0.5) and m.displacement_at_peak_m == pytest.approx(0.02)
    # Release where the falling side first drops below 2 mN; the trapezoid is exact on the piecewise-linear curve.
    xr = m.displacement_at_release_m
    below = x[(x > 0.02) & (f < 0.002)]
    assert xr == below[0]
    assert x[m.span_points - 1] == xr  # the toughness integrates up to the release point
    expected = 0.5 * 0.02 - 0.5 * (0.5 * (0.04 - xr) / 0.02) * (0.04 - xr)
    assert m.toughness_j == pytest.approx(expected, rel=1e-9)
    assert m.travel_m == x[-1]


def test_a_second_method_gets_its_own_peak_and_its_area_over_the_same_span():
    """A spike on the first method's curve (an object ringing on its weld) moves its peak, not the release; the
    second, spike-free curve's toughness is its own trapezoid up to the same release point."""
    x, f, touching = triangle(0.5, 0.02)
    spiked = f.copy()
    spiked[200] += 0.8  # one point at the peak (x = 20 mm): 0.8 N
    m = analyze_curve(x, spiked, touching, **CRITERIA, second_force_n=f)
    clean = analyze_curve(x, f, touching, **CRITERIA)
    assert m.displacement_at_release_m == clean.displacement_at_release_m
    assert m.peak_force_n == pytest.approx(1.3) and m.second_peak_force_n == pytest.approx(0.5)
    assert m.second_toughness_j == clean.toughness_j
    assert m.toughness_j == pytest.approx(clean.toughness_j + 0.8 * STEP_M, rel=1e-9)  # the spike's triangle
    assert math.isnan(clean.second_peak_force_n) and math.isnan(clean.second_toughness_j)
    with pytest.raises(ParameterError, match="second force"):
        analyze_curve(x, f, touching, **CRITERIA, second_force_n=f[:-1])


def test_slack_in_contact_is_not_a_release():
    x, f, touching = triangle(0.5, 0.02, slack_m=0.05)
    m = analyze_curve(x, f, touching, **CRITERIA)
    assert m.result == "released" and m.displacement_at_peak_m == pytest.approx(0.07)
    assert m.toughness_j == pytest.approx(0.5 * 0.02, rel=1e-3)


def test_no_load_is_slid_off_once_free_and_a_small_peak_too():
    x = np.arange(0.0, 0.05, STEP_M)
    m = analyze_curve(x, np.zeros_like(x), x < 0.02, **CRITERIA)
    assert m.result == "slid_off" and m.toughness_j == 0.0 and m.displacement_at_release_m == 0.0
    assert m.displacement_at_peak_m == 0.0 and m.peak_force_n == 0.0
    x, f, touching = triangle(0.01, 0.01)  # carried 10 mN, less than the 50 mN engagement force
    assert analyze_curve(x, f, touching, **CRITERIA).result == "slid_off"


def test_held_to_the_largest_travel_is_a_lower_bound():
    x = np.arange(0.0, 0.3 + STEP_M / 2, STEP_M)
    m = analyze_curve(x, np.full_like(x, 0.2), np.ones_like(x, dtype=bool), **CRITERIA)
    assert m.result == "held" and m.toughness_is_lower_bound
    assert m.toughness_j == pytest.approx(0.2 * 0.3) and math.isnan(m.displacement_at_release_m)
    short = analyze_curve(x[:10], np.full(10, 0.2), np.ones(10, dtype=bool), **CRITERIA)
    assert short.result == "" and math.isnan(short.toughness_j)
    with pytest.raises(ParameterError):
        analyze_curve(x, x[:-1], x, **CRITERIA)


def test_median_interval_is_the_median_iqr_and_a_seeded_percentile_bootstrap():
    values = [3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0, 6.0, float("nan")]
    summary = median_interval(values, seed=7)
    finite = np.array(values[:-1])
    assert summary.n == 8 and summary.median == np.median(finite)
    assert (summary.q25, summary.q75) == tuple(np.percentile(finite, [25, 75]))
    direct = stats.bootstrap(
        (finite,), np.median, method="percentile", n_resamples=9999, rng=np.random.default_rng(7)
    ).confidence_interval
    assert (summary.ci_low, summary.ci_high) == (direct.low, direct.high)
    assert summary.ci_low <= summary.median <= summary.ci_high
    assert median_interval(values, seed=7) == summary
    single = median_interval([2.0])
    assert single.median == 2.0 and math.isnan(single.ci_low)
    assert median_interval([]).n == 0
    same = median_interval([1.5, 1.5, 1.5])
    assert same.ci_low == same.ci_high == 1.5


def pull_rows(**columns) -> pd.DataFrame:
    base = {
        "condition": ["a"] * 4,
        "outcome": ["failure", "failure", "success", "unstable"],
        "pull_result": ["released", "slid_off", "held", ""],
        "peak_force_n": [1.0, 0.1, 2.0, 50.0],
        "toughness_j": [0.01, 0.0, 0.03, 9.0],
        "config.object_name": ["sphere"] * 4,
        "config.gripper.pressure_pa": [172e3] * 4,
    }
    return pd.DataFrame(base | columns)


def test_table_scores_stable_trials_only_beside_the_reference():
    table = pullout_table(pull_rows(), ["condition"]).iloc[0]
    assert (table["trials"], table["unstable"], table["scored"]) == (4, 1, 3)
    assert (table["released"], table["slid_off"], table["held"]) == (1, 1, 1)
    assert table["peak_force_median_n"] == 1.0 and table["toughness_median_j"] == 0.01
    assert table["peak_force_ci95_high_n"] <= 2.0  # the unstable trial's 50 N never enters
    assert table["reference_toughness_j"] == 0.010 and table["reference_max_force_n"] == REFERENCE_MAX_FORCE_N
    assert math.isnan(table["contact_toughness_median_j"]) and table["contact_scored"] == 0  # older rows
    second = {"contact_peak_force_n": [0.9, 0.2, 2.2, 40.0], "contact_toughness_j": [0.012, 0.0, 0.02, 8.0]}
    both = pullout_table(pull_rows(**second), ["condition"]).iloc[0]
    assert both["contact_peak_force_median_n"] == 0.9 and both["contact_toughness_median_j"] == 0.012
    assert both["contact_toughness_ci95_high_j"] <= 0.02 and both["toughness_median_j"] == 0.01
    assert both["contact_scored"] == 3  # the unstable row never enters
    other = pullout_table(pull_rows(**{"config.gripper.pressure_pa": [100e3] * 4}), ["condition"]).iloc[0]
    assert math.isnan(other["reference_toughness_j"])  # the reference measured at 172 kPa only
    bracket = pullout_table(pull_rows(**{"config.object_name": ["bracket"] * 4}), ["condition"]).iloc[0]
    assert math.isnan(bracket["reference_toughness_j"])


def test_rates_agree_when_the_bootstrap_intervals_overlap():
    assert intervals_overlap(0, 2, 1, 3) and not intervals_overlap(0, 1, 2, 3)
    assert not intervals_overlap(0, 1, 0, math.nan)
    slow = pull_rows(condition=["slow"] * 4)
    fast = pull_rows(condition=["fast"] * 4, toughness_j=[0.5, 0.6, 0.7, 0.0])
    rows = pd.concat([slow.assign(speed=0.01), fast.assign(speed=0.03)])
    table = pullout_table(rows, ["config.object_name", "speed"])
    agreement = rate_agreement(table, "config.object_name", "speed").iloc[0]
    assert agreement["speed_ratio"] == pytest.approx(3.0)
    assert agreement["peak_force_agrees"] and not agreement["toughness_agrees"]


def test_curve_point_names_its_series_columns():
    point = CurvePoint(
        displacement_m=0.1,
        pull_force_n=1.0,
        contact_pull_force_n=0.9,
        ground_pinch_pull_force_n=0.2,
        force_n=np.array([0.0, 0.0, 1.0]),
        contact_force_n=np.array([0.0, 0.0, 0.9]),
        weld_force_n=np.array([0.0, 0.0, -1.5]),
        contacts={kind: 1 for kind in KINDS},
        hub_work_j=0.2,
        damping_loss_j=0.01,
        constraint_work_j=-0.1,
        mechanical_energy_j=0.3,
    )
    series = point.as_series()
    assert series["force_n.z"] == 1.0 and series["weld_force_n.z"] == -1.5 and series["contacts.filament-object"] == 1
    assert series["ground_pinch_pull_force_n"] == 0.2
    assert len(series) == 8 + 3 * 3 + len(KINDS)
