"""benchmarks/bench_vector_ceiling.py's replay of copies as two blocks (docs/benchmarks.md)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).parents[2] / "benchmarks" / "bench_vector_ceiling.py"


@pytest.fixture(scope="module")
def ceiling():
    spec = importlib.util.spec_from_file_location("bench_vector_ceiling", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_lasting_imbalance_is_split_better_and_noise_is_not(ceiling):
    """A copy that always costs more is dealt a block of its own by the re-split; a cost that
    changes copy every step is not predicted by the step before."""
    lasting = np.tile([5.0, 1.0, 1.0, 1.0], (10, 1))  # (T, C) [ms]
    shares = ceiling.busy_shares(lasting, serial_ms=0.0)
    assert shares["fixed"] == pytest.approx(8.0 / (2 * 6.0))  # blocks 5 + 1 and 1 + 1
    assert shares["re-split"] == pytest.approx(8.0 / (2 * 5.0))  # 5 alone against 1 + 1 + 1
    assert shares["even"] == pytest.approx(1.0)
    moving = np.ones((12, 4))
    moving[np.arange(12), np.arange(12) % 4] = 5.0  # the costly copy changes every step
    shares = ceiling.busy_shares(moving, serial_ms=0.5)
    assert shares["re-split"] < shares["fixed"] < shares["even"] == pytest.approx(4.0 / 4.5)
