"""map_scene: the crosswalk and junction situations on karlsruhe, their listing and errors."""

import time

import numpy as np
import pytest

pytest.importorskip("lanelet2")

import marl_social
from marl_social.maps import MapError, load_map
from marl_social.maps.listing import scene_listing
from marl_social.scenarios import make_scenario

pytestmark = pytest.mark.filterwarnings("ignore::marl_social.maps.MapConversionWarning")


def _buildable(situation: str = "crosswalk"):
    return [e.element for e in scene_listing(load_map("karlsruhe"))
            if e.situation == situation and not e.reason]


JUNCTIONS = [42440, 45292, 45478, 585125576327414600]


def test_karlsruhe_crosswalks_listed_with_reasons():
    entries = [e for e in scene_listing(load_map("karlsruhe")) if e.situation == "crosswalk"]
    assert len(entries) == 8
    assert _buildable() == [44986, 45174]
    assert all(e.reason.startswith(f"crosswalk {e.element}: ") for e in entries if e.reason)


@pytest.mark.parametrize("element", [44986, 45174])
@pytest.mark.parametrize("pedestrian", ["crossing", "waiting", "none"])
def test_parallel_api(element, pedestrian):
    from pettingzoo.test import parallel_api_test

    env = marl_social.parallel_env(scenario="map_scene", map="karlsruhe", element=element,
                                   pedestrian=pedestrian, max_cycles=20)
    parallel_api_test(env, num_cycles=20)


@pytest.mark.parametrize("element", [44986, 45174])
def test_social_episode_without_collision(element):
    from marl_social.evaluation.run import run_episode

    result = run_episode("map_scene", seed=3, max_cycles=60, map="karlsruhe", element=element)
    assert not result.metrics["collision"]


def test_building_a_scene_is_fast():
    load_map("karlsruhe")
    for situation in ("crosswalk", "junction"):
        for element in _buildable(situation):
            start = time.process_time()
            make_scenario("map_scene", element=element, situation=situation).build(None)
            assert time.process_time() - start <= 0.5


def test_karlsruhe_junctions_listed_with_reasons():
    entries = [e for e in scene_listing(load_map("karlsruhe")) if e.situation == "junction"]
    assert _buildable("junction") == JUNCTIONS
    assert all(e.reason.startswith(f"junction {e.element}: ") and "\n" not in e.reason
               for e in entries if e.reason)


@pytest.mark.parametrize("element", JUNCTIONS)
@pytest.mark.parametrize("hidden_vehicle", ["near", "none"])
def test_junction_parallel_api(element, hidden_vehicle):
    from pettingzoo.test import parallel_api_test

    env = marl_social.parallel_env(scenario="map_scene", map="karlsruhe", situation="junction",
                                   element=element, hidden_vehicle=hidden_vehicle,
                                   max_cycles=20)
    parallel_api_test(env, num_cycles=20)


def test_junction_scene_roles():
    """The robot approaches on the minor lane; the hidden car, last, is the counterfactual's;
    a parked row hides it where the map's occluders do not."""
    scene = make_scenario("map_scene", situation="junction", element=585125576327414600)
    layout = scene.build(None)
    names = [a.name for a in layout.agents]
    assert names[0] == "robot_0" and names[-1] == f"human_{len(scene.plan.sensors)}"
    assert scene.hidden_agent().names == (names[-1],)
    assert len(scene.plan.parked_cars) >= 2
    assert all(any(np.array_equal(car, p) for p in layout.road_map.static_polygons)
               for car in scene.plan.parked_cars)


@pytest.mark.parametrize(("overrides", "words"), [
    ({"element": 12345}, "element 12345 is no element of the map"),
    ({"element": 45380}, "crosswalk 45380: no lane a car may use crosses it"),
    ({"element": 45170, "occluder": "human"}, "needs a lane beside a crossing lane"),
    ({"situation": "roundabout"}, "must be one of ('crosswalk', 'junction', 'signal')"),
    ({"situation": "junction", "element": 44988}, "junction 44988: signalized"),
    ({"situation": "junction", "element": 45556}, "nothing hides the major road"),
    ({"situation": "junction", "element": 12345}, "element 12345 is no junction of the map"),
])
def test_errors_are_one_line(overrides, words):
    with pytest.raises(ValueError) as err:
        make_scenario("map_scene", map="karlsruhe", **overrides)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_map_without_crosswalk(tmp_path):
    import re

    from tests.maps.synthetic import synthetic_osm

    text = re.sub(r'<relation id="102".*?</relation>', "", synthetic_osm(), flags=re.DOTALL)
    assert 'id="102"' not in text
    path = tmp_path / "no_crosswalk.osm"
    path.write_text(text)
    with pytest.raises(MapError, match="no element where a crosswalk scene can be built"):
        make_scenario("map_scene", map=str(path))
    with pytest.raises(MapError, match="element 100 is no crosswalk of the map"):
        make_scenario("map_scene", map=str(path), element=100)
