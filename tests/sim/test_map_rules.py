"""Stop lines, conflict zones and route crossings of the static map."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route, StopLine


def test_route_crosses_a_stop_line_at_its_arc_length():
    route = Route([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])  # east, then north
    np.testing.assert_allclose(route.segment_crossings([[4.0, -2.0], [4.0, 2.0]]), [4.0])
    np.testing.assert_allclose(route.segment_crossings([[8.0, 6.0], [12.0, 6.0]]), [16.0])
    assert route.segment_crossings([[20.0, -1.0], [20.0, 1.0]]).size == 0  # beyond its end
    with pytest.raises(ValueError, match="segment"):
        route.segment_crossings([[0.0, 0.0], [np.nan, 1.0]])


def test_conflict_zone_contains_points_and_checks_its_lanes():
    zone = ConflictZone(np.array([[0.0, 0.0], [0.0, 4.0], [4.0, 4.0], [4.0, 0.0]]), "box", (0,))
    inside = zone.contains(np.array([[2.0, 2.0], [4.5, 2.0], [-0.2, 1.0]]), margin_m=0.3)
    assert inside.tolist() == [True, False, True]
    lane = Lane(np.array([[-5.0, 2.0], [10.0, 2.0]]), 3.5, "eastbound")
    RoadMap(lanes=(lane,), crosswalks=(), static_polygons=(), conflict_zones=(zone,))
    with pytest.raises(ValueError, match="priority lanes"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(), conflict_zones=(zone,))


def test_stop_line_rejects_bad_kind_and_lane():
    with pytest.raises(ValueError, match="kind"):
        StopLine(np.array([[0.0, 0.0], [0.0, 1.0]]), kind="yield")
    line = StopLine(np.array([[0.0, 0.0], [0.0, 1.0]]), lane=3)
    with pytest.raises(ValueError, match="lane 3"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(), stop_lines=(line,))


def _signed_area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * float(x @ np.roll(y, -1) - y @ np.roll(x, -1))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(3, 9), seed=st.integers(0, 2**31 - 1), clockwise=st.booleans())
def test_convex_obstacles_are_kept_counter_clockwise_and_a_dent_is_refused(n, seed, clockwise):
    """A static obstacle is stored counter-clockwise (a clockwise one reversed, the same
    vertices); a vertex added on an edge and pushed inwards (a dent) makes it concave: a
    ValueError naming it."""
    rng = np.random.default_rng(seed)
    # n angles at least 0.3 rad apart: strictly convex, no three vertices in a line
    angles = np.cumsum(0.3 + rng.dirichlet(np.ones(n)) * (2.0 * np.pi - 0.3 * n))
    polygon = (rng.uniform(1.0, 20.0) * np.column_stack([np.cos(angles), np.sin(angles)])
               + rng.uniform(-50.0, 50.0, 2))
    if clockwise:
        polygon = polygon[::-1]
    road_map = RoadMap(lanes=(), crosswalks=(), static_polygons=(polygon,))
    stored = road_map.static_polygons[0]
    assert _signed_area(stored) > 0.0
    np.testing.assert_array_equal(stored, polygon[::-1] if clockwise else polygon)
    k = int(rng.integers(n))  # a vertex inserted inside edge k, pulled towards the middle
    dent = 0.9 * 0.5 * (polygon[k] + polygon[(k + 1) % n]) + 0.1 * polygon.mean(axis=0)
    dented = np.insert(polygon, k + 1, dent, axis=0)
    with pytest.raises(ValueError, match=r"static_polygons\[1\]: .*strictly convex"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(polygon, dented))


def test_an_obstacle_of_the_wrong_shape_or_with_nan_is_refused_by_name():
    with pytest.raises(ValueError, match=r"static_polygons\[0\]: expected a polygon"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(np.zeros((2, 2)),))
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    square[2, 0] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        RoadMap(lanes=(), crosswalks=(), static_polygons=(square,))


def test_an_agents_map_has_its_own_route_only_and_leaves_the_map_whole():
    """RoadMap.for_agent: the agent's own route and nothing of the others'; the map it came
    from keeps every route; the static rest is the same."""
    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    routes = {"robot_0": Route([[0.0, 0.0], [10.0, 0.0]]),
              "human_0": Route([[0.0, 3.0], [10.0, 3.0]])}
    road_map = RoadMap(lanes=(), crosswalks=(), static_polygons=(square,), routes=routes)
    robot_map = road_map.for_agent("robot_0")
    assert list(robot_map.routes) == ["robot_0"] and robot_map.routes["robot_0"] is routes["robot_0"]
    assert road_map.for_agent("pedestrian_0").routes == {}
    assert set(road_map.routes) == {"robot_0", "human_0"}
    assert robot_map.static_polygons is road_map.static_polygons
    assert isinstance(robot_map, RoadMap) and robot_map != road_map
