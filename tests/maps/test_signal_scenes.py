"""map_scene's signal situation (paper Fig. 1 c on a traffic light of karlsruhe)."""

import time

import numpy as np
import pytest

pytest.importorskip("lanelet2")

import marl_social
from marl_social.maps import load_map
from marl_social.maps.listing import scene_listing
from marl_social.maps.signal_scenes import signal_plan_of
from marl_social.scenarios import make_scenario
from marl_social.sim.road_map import Route
from marl_social.sim.signal_rules import route_signal_lines

pytestmark = pytest.mark.filterwarnings("ignore::marl_social.maps.MapConversionWarning")

SIGNALS = (45218, 45226)  # the traffic lights of karlsruhe where the situation can be built
SIGNAL = SIGNALS[0]


def test_karlsruhe_signals_listed_with_reasons():
    entries = [e for e in scene_listing(load_map("karlsruhe")) if e.situation == "signal"]
    assert [e.element for e in entries] == [45218, 45222, 45224, 45226, 45232, 45234]
    assert [e.element for e in entries if not e.reason] == list(SIGNALS)
    assert all(e.reason.startswith(f"traffic light {e.element}: ") and "\n" not in e.reason
               for e in entries if e.reason)


@pytest.mark.parametrize("element", SIGNALS)
@pytest.mark.parametrize("phase", ["protected_left", "cross_green"])
def test_parallel_api(phase, element):
    from pettingzoo.test import parallel_api_test

    env = marl_social.parallel_env(scenario="map_scene", map="karlsruhe", situation="signal",
                                   element=element, phase=phase, max_cycles=20)
    parallel_api_test(env, num_cycles=20)


def test_roles_and_phases():
    """Robot turning right on red in both variants; left-turners' green is the cross red."""
    loaded = load_map("karlsruhe")
    plan = signal_plan_of(loaded, SIGNAL)
    scene = make_scenario("map_scene", map="karlsruhe", situation="signal", element=SIGNAL)
    layout = scene.build(np.random.default_rng(0))
    road_map = layout.road_map
    cycle = road_map.signal_plan
    robot, cross, left = plan.groups
    protected, cross_green = (cycle.phases[k] for k in plan.phase_indices)
    assert left in protected.green and robot not in protected.green + protected.yellow
    assert cross not in protected.green + protected.yellow
    assert cross in cross_green.green and robot not in cross_green.green + cross_green.yellow
    assert left not in cross_green.green + cross_green.yellow
    names = [spec.name for spec in layout.agents]
    assert names == ["robot_0", "human_0", "human_1", "human_2", "human_3"]
    # every driver's route crosses its own light's line (it stops there on red)
    for name, group in (("robot_0", robot), ("human_0", left), ("human_2", cross)):
        _, heads = route_signal_lines(road_map.routes[name], road_map)
        assert len(heads) and road_map.signal_heads[int(heads[0])].group == group
    _, heading = Route(plan.robot.points).point_at(
        np.array([plan.robot.crossing_m, plan.robot.crossing_m + 25.0]))
    assert np.unwrap(heading)[1] - heading[0] < -np.radians(45.0)  # a right turn


def test_building_a_signal_scene_is_fast():
    load_map("karlsruhe")
    make_scenario("map_scene", situation="signal", element=SIGNAL)  # kernels compiled
    start = time.process_time()
    make_scenario("map_scene", situation="signal", element=SIGNAL).build(None)
    assert time.process_time() - start <= 0.5


@pytest.mark.parametrize(("overrides", "words"), [
    ({"element": 44986}, "element 44986 is no traffic light of the map"),
    ({"element": 45222}, ("traffic light 45222: no lane of it that crosses its stop line "
                          "turns right")),
    ({"element": SIGNAL, "phase_elapsed_s": 30.0}, ("must be less than the protected_left "
                                                   "phase's 20 s")),
    ({"element": SIGNAL, "phase": "green"}, "phase='green': must be one of"),
])
def test_errors_are_one_line(overrides, words):
    with pytest.raises(ValueError) as err:
        make_scenario("map_scene", map="karlsruhe", situation="signal", **overrides)
    assert words in str(err.value) and "\n" not in str(err.value)
