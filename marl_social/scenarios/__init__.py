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
}
# scenes built on a file of the user's (a recording): not among SCENARIOS, which every generic
# check builds with its defaults; make_scenario builds them too
RECORDING_SCENARIOS: dict[str, type[Scenario]] = {MapReplay.name: MapReplay}


def make_scenario(name: str, **overrides) -> Scenario:
    """Instantiate a registered scenario with validated overrides."""
    known = {**SCENARIOS, **RECORDING_SCENARIOS}
    if not isinstance(name, str) or name not in known:
        raise ValueError(f"unknown scenario {name!r}; available: {sorted(SCENARIOS)}")
    return known[name](**overrides)


__all__ = ["RECORDING_SCENARIOS", "SCENARIOS", "Scenario", "ScenarioLayout", "ScenarioParams",
           "make_params", "make_scenario"]
