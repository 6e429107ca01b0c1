"""map_scene's traffic knob: extra drivers on karlsruhe's lanes near the element."""

import time

import numpy as np
import pytest

pytest.importorskip("lanelet2")

import marl_social
from marl_social.maps import load_map
from marl_social.maps.traffic import TRAFFIC_GAP_M
from marl_social.scenarios import make_scenario

pytestmark = pytest.mark.filterwarnings("ignore::marl_social.maps.MapConversionWarning")

TEN_AGENTS = [{"element": 44986, "n_traffic": 7},
              {"situation": "signal", "element": 45218, "n_traffic": 5}]


@pytest.mark.parametrize("overrides", TEN_AGENTS)
def test_ten_agents_spaced_apart(overrides):
    layout = make_scenario("map_scene", map="karlsruhe", **overrides).build(None)
    assert len(layout.agents) == 10
    traffic = layout.agents[10 - overrides["n_traffic"]:]
    assert all(spec.role == "human" for spec in traffic)
    xy = np.array([spec.initial_state[:2] for spec in layout.agents])
    for spec in traffic:
        gaps = np.linalg.norm(xy - spec.initial_state[:2], axis=1)
        assert np.sort(gaps)[1] >= TRAFFIC_GAP_M  # [0]: itself
    for spec in traffic:  # each starts on its route
        route = layout.road_map.routes[spec.name]
        _, lateral, _ = route.project(spec.initial_state[None, :2])
        assert abs(lateral[0]) < 1e-6


@pytest.mark.parametrize("overrides", TEN_AGENTS)
def test_parallel_api(overrides):
    from pettingzoo.test import parallel_api_test

    env = marl_social.parallel_env(scenario="map_scene", map="karlsruhe", max_cycles=20,
                                   **overrides)
    parallel_api_test(env, num_cycles=20)


def test_nobody_starts_in_a_collision():
    from marl_social.evaluation.run import run_episode

    result = run_episode("map_scene", seed=0, max_cycles=30, map="karlsruhe",
                         **TEN_AGENTS[0])
    assert not result.metrics["collision"]


def test_building_a_ten_agent_scene_is_fast():
    load_map("karlsruhe")
    make_scenario("map_scene", **TEN_AGENTS[1])  # kernels compiled
    start = time.process_time()
    make_scenario("map_scene", **TEN_AGENTS[1]).build(None)
    assert time.process_time() - start <= 0.5


def test_too_much_traffic_is_a_one_line_error():
    with pytest.raises(ValueError) as err:
        make_scenario("map_scene", map="karlsruhe", situation="junction", element=42440,
                      n_traffic=20)
    assert "traffic cars near element 42440, n_traffic=20 asked for" in str(err.value)
    assert "\n" not in str(err.value)
