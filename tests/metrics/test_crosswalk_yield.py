"""The crosswalk part of `yielded` (metrics/physical.py) on a crosswalk wider than the robot's
lane and the one beside it (a real street's: it also spans the oncoming lane)."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.metrics.physical import pedestrian_before_robot_lane, yielded
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Crosswalk, Lane, RoadMap, Route
from marl_social.sim.trace import Trace

N_STEPS = 100  # 10 s
LANE_WIDTH_M = 3.5
CROSSWALK_X_M = 50.0


def _road_map(crosswalk_length_m: float) -> RoadMap:
    """Eastbound lanes at y = -3.5 (the human's) and 0 (the robot's), a westbound one at y =
    3.5; a crosswalk at x = 50 (walking north) of the given length about y = 0."""
    lanes = (Lane(np.array([[0.0, -LANE_WIDTH_M], [100.0, -LANE_WIDTH_M]]), LANE_WIDTH_M),
             Lane(np.array([[0.0, 0.0], [100.0, 0.0]]), LANE_WIDTH_M),
             Lane(np.array([[100.0, LANE_WIDTH_M], [0.0, LANE_WIDTH_M]]), LANE_WIDTH_M))
    crosswalk = Crosswalk(np.array([CROSSWALK_X_M, 0.0]), 0.5 * np.pi, crosswalk_length_m, 4.0)
    routes = {"robot_0": Route(np.array([[0.0, 0.0], [100.0, 0.0]]), "robot_0"),
              "pedestrian_0": Route(np.array([[CROSSWALK_X_M, -7.0], [CROSSWALK_X_M, 7.0]]),
                                    "pedestrian_0")}
    return RoadMap(lanes, (crosswalk,), (), routes)


def _trace(robot_x: np.ndarray, pedestrian_y: np.ndarray) -> Trace:
    """robot_0 at x = robot_x on y = 0, pedestrian_0 at y = pedestrian_y on x = 50 (T+1,) [m]."""
    states = np.zeros((N_STEPS + 1, 2, 4))
    states[:, 0, 0], states[:, 0, 3] = robot_x, np.gradient(robot_x, DT_S)
    states[:, 1, 0], states[:, 1, 1] = CROSSWALK_X_M, pedestrian_y
    states[:, 1, 2] = 0.5 * np.pi
    trace = Trace(["robot_0", "pedestrian_0"], ["robot", "pedestrian"], np.array([2.45, 0.3]))
    trace.times_s = np.arange(N_STEPS + 1) * DT_S
    trace.states = states
    trace.active = np.ones((N_STEPS + 1, 2), bool)
    trace.visible = np.zeros((N_STEPS + 1, 2, 2), bool)
    trace.actions = np.zeros((N_STEPS, 2, 2))
    trace.accel_mps2 = np.zeros((N_STEPS, 2))
    trace.rewards = np.zeros((N_STEPS, 2))
    trace.collided = np.zeros((N_STEPS, 2), bool)
    return trace


T = np.arange(N_STEPS + 1) * DT_S
PEDESTRIAN_Y = -6.0 + 1.2 * T  # from the human's side at 1.2 m/s: y = 0 at 5 s


@pytest.mark.parametrize("robot_at_crosswalk_s, gives_way", [(4.0, False), (5.5, False),
                                                             (7.5, True)])
def test_the_robot_passes_behind_a_pedestrian_past_its_lane(robot_at_crosswalk_s, gives_way):
    """On a crosswalk over three lanes the pedestrian is still on it, in the oncoming lane,
    when the robot crosses behind it (7.5 s: y = 3); before (4 s, 5.5 s) it is in its way."""
    road_map = _road_map(3 * LANE_WIDTH_M + 2.0)
    robot_x = CROSSWALK_X_M + 8.0 * (T - robot_at_crosswalk_s)
    trace = _trace(robot_x, PEDESTRIAN_Y)
    assert yielded(trace, road_map, "robot_0") is gives_way


def test_on_a_curb_to_curb_crosswalk_in_it_is_before_the_lane_edge():
    """Where the crosswalk ends at the robot's lane's far edge, the pedestrian on it has not
    walked past the robot's lane: the rule is the crosswalk's alone."""
    road_map = _road_map(2 * LANE_WIDTH_M)
    road_map = RoadMap(road_map.lanes, (Crosswalk(np.array([CROSSWALK_X_M, -0.5 * LANE_WIDTH_M]),
                                                  0.5 * np.pi, 2 * LANE_WIDTH_M, 4.0),),
                       (), road_map.routes)
    trace = _trace(CROSSWALK_X_M + 8.0 * (T - 7.5), PEDESTRIAN_Y)
    before = pedestrian_before_robot_lane(trace, road_map, "robot_0", 1)
    in_crosswalk = road_map.crosswalks[0].contains(trace.states[:, 1, :2])
    assert np.all(before[in_crosswalk])
    assert not yielded(_trace(CROSSWALK_X_M + 8.0 * (T - 6.0), PEDESTRIAN_Y), road_map,
                       "robot_0")
