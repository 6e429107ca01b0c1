"""The robot predicts a tracked car in a lane along its lane path (track_prediction.py)."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import MpcConfig, PlanRequest
from marl_social.agents.robot.track_prediction import along_lane_paths
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief.paths import LanePaths
from marl_social.perception.tracking import TrackSet
from marl_social.scenarios import make_scenario
from marl_social.scenarios.t_intersection import LEFT_TURN_LANE_Y_M
from marl_social.sim.agent_spec import VehicleParams

CAR = VehicleParams()
TIMES = MpcConfig().plan_times_s  # (N,) [s]
HEADING_ERROR_RAD = 0.12  # a slow car's track heading 7 degrees off its lane (measured)


@pytest.fixture(scope="module")
def road_map():
    layout = make_scenario("t_intersection", hidden_vehicle="none").build(
        np.random.default_rng(0))
    return layout.road_map


def _tracks(xy, speed_mps, heading_rad, pedestrian) -> TrackSet:
    """Tracks at xy (k, 2) [m] moving at speed_mps (k,) [m/s] along heading_rad (k,) [rad]."""
    xy, speed, heading = (np.asarray(a, dtype=np.float64) for a in (xy, speed_mps, heading_rad))
    k = len(xy)
    size = np.where(pedestrian, 0.6, CAR.length_m), np.where(pedestrian, 0.6, CAR.width_m)
    return TrackSet(ids=np.arange(1, k + 1), xy=xy,
                    velocity=speed[:, None] * np.stack([np.cos(heading), np.sin(heading)], -1),
                    pos_std_m=np.zeros(k), length_m=size[0], width_m=size[1],
                    is_pedestrian=np.asarray(pedestrian, bool), seen=np.ones(k, bool),
                    age_unseen_s=np.zeros(k), heading_rad=heading)


def test_a_car_read_off_its_lane_is_predicted_along_its_path(road_map):
    """A slow left-turner whose track points 7 degrees off its lane (towards the eastbound
    lane) stays on its lane path, through its turn, at its speed along the path; a pedestrian
    and a car driving against every lane keep their constant-velocity prediction."""
    turn_heading = -(np.pi - HEADING_ERROR_RAD)
    tracks = _tracks([[17.4, LEFT_TURN_LANE_Y_M], [30.0, -4.0], [40.0, -1.75]],
                     [3.2, 1.4, 5.0], [turn_heading, 0.5 * np.pi, np.pi],
                     [False, True, False])
    lane_paths = LanePaths(road_map)
    constant = ScenePrediction.from_tracks(tracks, TIMES)
    scene = along_lane_paths(constant, tracks, lane_paths, TIMES)
    path = lane_paths.route_of(tracks.xy[0], turn_heading)
    s, lateral, _ = path.project(scene.xy[0, 0])
    np.testing.assert_allclose(lateral, 0.0, atol=1e-9)  # on the path's centre line
    speed_along = 3.2 * np.cos(HEADING_ERROR_RAD)
    np.testing.assert_allclose(np.diff(s), speed_along * np.diff(TIMES), rtol=1e-9)
    # through its turn: across the eastbound lane west of the stem's centre line
    assert scene.xy[0, 0, -1, 0] < 0.0 and scene.xy[0, 0, -1, 1] < -1.0
    _, path_heading = path.point_at(s)
    np.testing.assert_allclose(scene.heading[0, 0], path_heading)
    # constant velocity drifts it more than a metre off its path within the plan's 6 s
    _, drift, _ = path.project(constant.xy[0, 0])
    assert np.max(np.abs(drift)) > 1.0
    for k in (1, 2):  # the pedestrian; the car against the eastbound lane
        np.testing.assert_array_equal(scene.xy[0, k], constant.xy[0, k])
        np.testing.assert_array_equal(scene.heading[0, k], constant.heading[0, k])


def test_the_robot_turning_into_its_lane_does_not_brake_for_a_car_read_off_its_lane(road_map):
    """The robot has turned into the eastbound lane at 3.8 m/s (T-intersection, seed 0 of its
    claims); a left-turner braking in the westbound turn lane reads 7 degrees off its lane.
    Predicted along its lane path it turns behind the robot and the plan keeps going;
    predicted at constant velocity it drifts into the robot's lane, no plan keeps out of its
    way, and the robot brakes at its limit (8 m/s^2), as it did in that episode."""
    route = road_map.routes["robot_0"]
    tracks = _tracks([[17.44, LEFT_TURN_LANE_Y_M]], [3.2], [-(np.pi - HEADING_ERROR_RAD)],
                     [False])
    constant = ScenePrediction.from_tracks(tracks, TIMES)
    scenes = {"constant velocity": constant,
              "lane path": along_lane_paths(constant, tracks, LanePaths(road_map), TIMES)}
    accel = {}
    for name, scene in scenes.items():
        result = ContingencyMpc(MpcConfig(), CAR).plan(route, PlanRequest(59.77, 3.81, 0.0, 11.0,
                                                        road_map.speed_limit_mps, scene,
                                                        np.ones(1)))
        accel[name] = (result.feasible, result.accel_mps2)
    assert accel["lane path"][0] and accel["lane path"][1] >= 0.0, accel
    # no plan keeps out of its way: braking at the limit
    assert accel["constant velocity"][1] <= -CAR.brake_max_mps2 + 1e-9, accel
