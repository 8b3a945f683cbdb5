"""Seeded trial rows pinned before the harness refactor: the same inputs must give the same row.

Regenerate deliberately with `python -m tests.data.make_pinned_rows` when the physics defaults change. On a
machine with the generating machine's floating point (same `float_fingerprint`) every column must match to
1e-9; elsewhere the outcome columns must (see tests/data/make_pinned_rows.py for the measured spread).
"""

import json

import pytest

from entangle_bench.runner import run_trial
from tests.data.make_pinned_rows import (
    COLUMNS,
    LIFT_TOLERANCE,
    PATH,
    UNSTABLE_TIME_TOLERANCE_S,
    float_fingerprint,
    pinned_columns,
    spec_of,
)

PINNED = json.loads(PATH.read_text())


def case_id(pinned: dict) -> str:
    """Readable test id: task, preset, seed, offset."""
    case = pinned["case"]
    return f"{case['task']}-{case['preset']}-seed{case['seed']}-offset{case['offset_m']}-{len(case['overrides'])}"


@pytest.fixture(scope="module")
def same_floating_point() -> bool:
    """Whether this machine computes the generating machine's floating point bit for bit."""
    return float_fingerprint() == PINNED["fingerprint"]


@pytest.mark.parametrize("pinned", PINNED["rows"], ids=case_id)
def test_row_is_unchanged(pinned, same_floating_point):
    spec = spec_of(pinned["case"])
    assert spec.trial_id == pinned["row"]["trial_id"]
    row = pinned_columns(run_trial(spec))
    expected = pinned["row"]
    assert sorted(row) == sorted(expected)
    for key, value in expected.items():
        if same_floating_point and isinstance(value, float):
            assert row[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
        elif same_floating_point:
            assert row[key] == value, key
        elif key == "lift_clearance_m":
            assert row[key] == pytest.approx(value, rel=LIFT_TOLERANCE), key
        elif key == "unstable_time_s" and value is not None:
            assert row[key] == pytest.approx(value, abs=UNSTABLE_TIME_TOLERANCE_S), key
        elif key in COLUMNS:
            assert row[key] == value, key
