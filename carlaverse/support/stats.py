"""The percentile every report, test and benchmark of this project takes (one definition)."""

from __future__ import annotations

from collections.abc import Sequence


def percentile(values: Sequence[float], q: float) -> float:
    """The q-quantile (0..1): the value at rank round(q·(n − 1)) of the sorted values, the
    sample nearest the quantile's position (numpy's `method="nearest"`); NaN for no values."""
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q * (len(ordered) - 1))))]
