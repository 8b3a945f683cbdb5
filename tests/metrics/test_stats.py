"""Wilson intervals against published values."""

import pytest

from entangle_bench.errors import ParameterError
from entangle_bench.metrics.stats import wilson_interval


@pytest.mark.parametrize(
    ("k", "n", "low", "high"),
    # Newcombe, Statistics in Medicine 17 (1998) 857, Table II, method 3 (score interval, no correction).
    [(81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718)],
)
def test_wilson_interval_matches_newcombe_1998(k, n, low, high):
    assert wilson_interval(k, n) == pytest.approx((low, high), abs=1e-4)


def test_wilson_interval_rejects_impossible_counts():
    with pytest.raises(ParameterError, match="between 0 and trials"):
        wilson_interval(3, 2)
