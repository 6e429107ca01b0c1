"""Shared settings of the property-based (hypothesis) tests: fixed seed, bounded, deadlines.

Every fuzz suite decorates its tests with `FUZZ` (or `fuzz(n)`): examples are derived from the
test itself (`derandomize=True`), nothing is stored between runs (`database=None`), and each
example must finish within its deadline, so a hang fails the test instead of stalling CI.
"""

from __future__ import annotations

from datetime import timedelta

from hypothesis import HealthCheck, settings


def fuzz(max_examples: int, deadline_s: float = 2.0) -> settings:
    """Hypothesis settings: `max_examples` derandomized examples, each within `deadline_s`."""
    return settings(max_examples=max_examples, derandomize=True, database=None,
                    deadline=timedelta(seconds=deadline_s), print_blob=False,
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])


FUZZ = fuzz(100)
