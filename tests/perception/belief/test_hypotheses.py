"""Pedestrian hypotheses of a map (perception/belief/hypotheses.py)."""

from __future__ import annotations

import numpy as np
import pytest
from marl_social.perception.belief import crosswalk_hypotheses

from tests.perception.belief.episodes import CROSSWALK_X_M, paper_env


def test_crosswalk_hypotheses_of_the_paper_map():
    env = paper_env()
    hyps = crosswalk_hypotheses(env.road_map, walk_speed_mps=1.3, curb_offset_m=1.0)
    assert [h.name for h in hyps] == ["none", "crossing_right", "crossing_left"]
    assert not hyps[0].present and hyps[1].present and hyps[2].present
    right, left = hyps[1], hyps[2]
    np.testing.assert_allclose(right.start_xy, [CROSSWALK_X_M, -4.5])  # curb y = -3.5
    np.testing.assert_allclose(right.walk_dir, [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(left.start_xy, [CROSSWALK_X_M, 4.5])
    xy = right.predict_xy(np.array([0.0, 1.0, 100.0]))
    np.testing.assert_allclose(xy, [[60.0, -4.5], [60.0, -3.2], [60.0, 4.5]], atol=1e-12)
    region = right.region()
    assert region.shape[1] == 2 and len(region) >= 9
    assert region[:, 1].min() >= -5.0 - 1e-9 and region[:, 1].max() <= -2.5 + 1e-9
    assert np.abs(region[:, 0] - CROSSWALK_X_M).max() <= 2.0
    with pytest.raises(ValueError):
        hyps[0].predict_xy(np.array([0.0]))
