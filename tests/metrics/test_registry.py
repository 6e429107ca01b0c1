"""The metric registry: names, order, computation and errors (marl_social/metrics/)."""

from __future__ import annotations

import math

import pytest

import marl_social
from marl_social.metrics import (
    belief_metrics,
    compute_metrics,
    episode_metrics,
    metric_names,
    register_metric,
)
from marl_social.studies.runs import available_metrics


@pytest.fixture(scope="module")
def episode():
    return marl_social.run_episode("occluded_crosswalk", seed=0, max_cycles=40)


def _same(a, b) -> bool:
    return a == b or (isinstance(a, float) and math.isnan(a) and math.isnan(b))


def test_every_registered_name_is_in_run_episode_metrics_in_order(episode):
    assert tuple(episode.metrics) == metric_names()
    assert metric_names() == metric_names("episode") + metric_names("belief")
    assert len(set(metric_names())) == len(metric_names())


def test_groups_are_the_two_metric_sets(episode):
    trace, road_map = episode.trace, episode.road_map
    assert tuple(episode_metrics(trace, road_map)) == metric_names("episode")
    assert tuple(belief_metrics(trace, road_map)) == metric_names("belief")
    assert "hard_brake" in metric_names("episode") and "brier" in metric_names("belief")


def test_compute_metrics_by_name_matches_run_episode(episode):
    names = ("yielded", "max_jerk_mps3", "brier", "mean_speed_mps")
    values = compute_metrics(episode.trace, episode.road_map, names=names)
    assert tuple(values) == names
    assert all(_same(values[n], episode.metrics[n]) for n in names)
    everything = compute_metrics(episode.trace, episode.road_map)
    assert all(_same(everything[n], episode.metrics[n]) for n in metric_names())


def test_unknown_metric_name_is_a_clear_error(episode):
    with pytest.raises(ValueError, match=r"unknown metric\(s\) \['happiness'\].*registered"):
        compute_metrics(episode.trace, episode.road_map, names=["yielded", "happiness"])


def test_registering_a_taken_name_fails():
    with pytest.raises(ValueError, match="already registered"):
        register_metric("yielded", group="episode")(lambda trace, road_map, robot: True)
    assert metric_names().count("yielded") == 1


def test_studies_available_metrics_are_the_registry_names():
    for scenario in ("occluded_crosswalk", "long_road"):
        assert available_metrics(scenario) == metric_names()
        assert available_metrics(scenario) == tuple(
            marl_social.run_episode(scenario, seed=0, max_cycles=1).metrics)
    with pytest.raises(ValueError, match="unknown scenario"):
        available_metrics("moon_base")
