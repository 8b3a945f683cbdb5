"""Seeded trial rows pinned before the harness refactor: the same inputs must give the same row.

Regenerate deliberately with `python -m tests.data.make_pinned_rows` when the physics defaults change.
"""

import json

import pytest

from entangle_bench.runner import run_trial
from tests.data.make_pinned_rows import PATH, pinned_columns, spec_of

PINNED = json.loads(PATH.read_text())


def case_id(pinned: dict) -> str:
    """Readable test id: task, preset, seed, offset."""
    case = pinned["case"]
    return f"{case['task']}-{case['preset']}-seed{case['seed']}-offset{case['offset_m']}-{len(case['overrides'])}"


@pytest.mark.parametrize("pinned", PINNED, ids=case_id)
def test_row_is_unchanged(pinned):
    spec = spec_of(pinned["case"])
    assert spec.trial_id == pinned["row"]["trial_id"]
    row = pinned_columns(run_trial(spec))
    expected = pinned["row"]
    assert sorted(row) == sorted(expected)
    for key, value in expected.items():
        if isinstance(value, float):
            assert row[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
        else:
            assert row[key] == value, key
