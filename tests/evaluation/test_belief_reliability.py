"""The belief's reliability numbers (evaluation/belief_reliability.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marl_social.evaluation.belief_reliability import (
    SCENE_PAIRS,
    Cell,
    belief_before_reference,
    belief_key,
    brier_score,
    crossings,
    holds_once_confident,
    reliability_bins,
    reliability_episode,
    reliability_points,
)


def test_a_belief_that_climbs_and_falls_back_crosses_one_half_many_times():
    """The issue's example series: 0.49 -> 0.30 -> 0.15 -> 0.31 -> 0.83 -> 0.59 -> 0.88."""
    assert crossings(np.array([0.49, 0.30, 0.15, 0.31, 0.83, 0.59, 0.88])) == 1
    assert crossings(np.array([0.2, 0.96, 0.04, 0.6])) == 3
    assert crossings(np.array([0.1, np.nan, 0.2])) == 0


def test_a_confident_belief_holds_unless_it_falls_below_one_half():
    assert holds_once_confident(np.array([0.2, 0.95, 0.6, 0.99]))
    assert not holds_once_confident(np.array([0.2, 0.96, 0.04]))
    assert not holds_once_confident(np.array([0.2, 0.8]))  # never confident


def test_reliability_bins_and_brier_score():
    p = np.array([0.05, 0.05, 0.95, 0.95, np.nan])
    y = np.array([0.0, 0.0, 1.0, 0.0, 1.0])
    bins = reliability_bins(p, y)
    assert [(b["n"], b["frequency"]) for b in bins] == [(2, 0.0), (2, 0.5)]
    assert brier_score(p, y) == pytest.approx((3 * 0.05 ** 2 + 0.95 ** 2) / 4)
    assert reliability_bins([1.0], [1.0])[0]["hi"] == 1.0  # a belief of 1 is in the top bin


def test_the_diagram_reads_both_populations_before_the_reference():
    present = {"reference_s": 1.0, "dt_s": 0.1, "belief": np.linspace(0.0, 1.0, 11)}
    absent = {"reference_s": math.nan, "dt_s": 0.1, "belief": np.zeros(11)}
    assert belief_before_reference(present, 0.5) == pytest.approx(0.5)
    assert math.isnan(belief_before_reference(present, 2.0))  # before the episode began
    p, y = reliability_points([present], [absent], before_s=(0.5,))
    assert p.tolist() == pytest.approx([0.5, 0.0]) and y.tolist() == [1.0, 0.0]


def test_each_scene_reads_the_belief_in_what_it_hides():
    assert belief_key("occluded_crosswalk") == "p_pedestrian"
    assert belief_key("t_intersection") == "p_vehicle"
    assert belief_key("signalized_intersection") == "phase_protected_left"
    with pytest.raises(ValueError, match="hides nothing"):
        belief_key("long_road")


def test_one_reliability_episode_reports_the_warning_and_the_belief():
    cell = Cell("occluded_crosswalk", "social", {"pedestrian": "crossing"}, 40, True)
    name, seed, summary, error = reliability_episode(("c", cell, 10_001))
    assert error is None and (name, seed) == ("c", 10_001)
    assert summary["lead_s"] >= 0.0 or math.isnan(summary["reference_s"])
    assert len(summary["belief"]) == 41
    assert set(SCENE_PAIRS) == {"occluded_crosswalk", "t_intersection",
                                "signalized_intersection"}
