"""map_scene: the crosswalk situation on karlsruhe's crosswalks, its listing and its errors."""

import time

import pytest

pytest.importorskip("lanelet2")

import marl_social
from marl_social.maps import MapError, load_map
from marl_social.maps.scenes import scene_listing
from marl_social.scenarios import make_scenario

pytestmark = pytest.mark.filterwarnings("ignore::marl_social.maps.MapConversionWarning")


def _buildable():
    return [e.element for e in scene_listing(load_map("karlsruhe"))
            if e.situation == "crosswalk" and not e.reason]


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
    for element in _buildable():
        start = time.process_time()
        make_scenario("map_scene", element=element).build(None)
        assert time.process_time() - start <= 0.5


@pytest.mark.parametrize(("overrides", "words"), [
    ({"element": 12345}, "element 12345 is no element of the map"),
    ({"element": 45380}, "crosswalk 45380: no lane a car may use crosses it"),
    ({"element": 45170, "occluder": "human"}, "needs a lane beside a crossing lane"),
    ({"situation": "junction"}, "must be one of ('crosswalk',)"),
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
