"""Scenario registry: name -> Scenario class."""

from __future__ import annotations

from marl_social.scenarios.base import Scenario, ScenarioLayout, ScenarioParams, make_params
from marl_social.scenarios.long_road import LongRoad
from marl_social.scenarios.map_replay import MapReplay
from marl_social.scenarios.map_scene import MapScene
from marl_social.scenarios.occluded_crosswalk import OccludedCrosswalk
from marl_social.scenarios.signalized_intersection import SignalizedIntersection
from marl_social.scenarios.t_intersection import TIntersection

SCENARIOS: dict[str, type[Scenario]] = {
    OccludedCrosswalk.name: OccludedCrosswalk,
    LongRoad.name: LongRoad,
    TIntersection.name: TIntersection,
    SignalizedIntersection.name: SignalizedIntersection,
    MapScene.name: MapScene,
    MapReplay.name: MapReplay,
}


def make_scenario(name: str, **overrides) -> Scenario:
    """Instantiate a registered scenario with validated overrides."""
    if not isinstance(name, str) or name not in SCENARIOS:
        raise ValueError(f"unknown scenario {name!r}; available: {sorted(SCENARIOS)}")
    return SCENARIOS[name](**overrides)


__all__ = ["SCENARIOS", "Scenario", "ScenarioLayout", "ScenarioParams", "make_params",
           "make_scenario"]
