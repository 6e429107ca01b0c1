"""The combined belief (perception/belief/pedestrian.py; Algorithm 1): the traffic-speed
product over humans (eq. 12), the epsilon threshold and robustness to absurd inputs."""

from __future__ import annotations

import numpy as np

from marl_social.perception.belief import BeliefConfig, PedestrianBelief
from marl_social.sim.observation import EGO_DIM, EGO_INDEX, SLOT_DIM, SLOT_INDEX
from marl_social.sim.road_map import RoadMap
from tests.perception.belief.episodes import paper_env, synthetic_world


def test_traffic_speed_belief_multiplies_over_humans():
    """Two humans holding 13 m/s concentrate the v_traffic belief on 13 more than one does."""
    road_map, layout, names, observe = synthetic_world(2)
    p13 = {}
    for visible in ((0,), (0, 1)):
        belief = PedestrianBelief(road_map, layout, "robot_0", names,
                                  BeliefConfig(v_traffic_grid_mps=(8.0, 10.0, 11.5, 13.0)))
        assert [h.name for h in belief.hypotheses] == ["none"]
        for step in range(12):
            belief.update(observe(0.1 * step, visible))
        grid = list(belief.traffic.grid_mps)
        p13[len(visible)] = belief.traffic.probabilities[grid.index(13.0)]
        assert abs(belief.traffic.expected_mps - 13.0) < 1.0
    assert 0.25 < p13[1] < p13[2]
    assert 1.0 - p13[2] < 0.5 * (1.0 - p13[1])


def test_live_excludes_hypotheses_below_epsilon():
    env = paper_env()
    belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0", env.possible_agents,
                              BeliefConfig(epsilon=0.02))
    belief.probabilities = np.array([0.97, 0.019, 0.011])
    np.testing.assert_array_equal(belief.live(), [True, False, False])
    np.testing.assert_array_equal(belief.live(0.015), [True, True, False])
    np.testing.assert_array_equal(belief.live(0.01), [True, True, True])
    belief.probabilities = np.array([0.96, 0.02, 0.02])
    np.testing.assert_array_equal(belief.live(), [True, True, True])  # b >= epsilon is live


def test_belief_never_nan_or_all_zero_with_absurd_inputs():
    """A human track whose velocity jumps by +-1000 m/s every step (a_obs = +-1e4 m/s^2, far
    outside the action set), NaN depth rays and a huge speed: the belief stays a finite,
    strictly positive distribution."""
    road_map, layout, names, observe = synthetic_world(1)
    env = paper_env()
    crosswalk_map = RoadMap(lanes=env.road_map.lanes, crosswalks=env.road_map.crosswalks,
                            static_polygons=(), routes=road_map.routes)
    for rm in (road_map, crosswalk_map):
        belief = PedestrianBelief(rm, layout, "robot_0", names)
        for step in range(20):
            obs = observe(0.1 * step, (0,))
            obs[EGO_DIM + SLOT_INDEX["vx"]] = 1000.0 * (-1) ** step
            if step % 3 == 0:
                obs[EGO_DIM + layout.n_slots * SLOT_DIM:] = np.nan
            if step % 5 == 0:
                obs[EGO_INDEX["v"]] = 1e4
            p = belief.update(obs)
            assert np.all(np.isfinite(p)) and p.min() > 0 and abs(p.sum() - 1.0) < 1e-9
            assert np.all(np.isfinite(belief.traffic.probabilities))
            assert 0.0 <= belief.p_pedestrian <= 1.0


def test_the_robot_tracks_with_its_own_sensor_noise():
    """robot_configs hands the robot's sensor noise to its belief's Kalman tracker."""
    import marl_social
    from marl_social.agents.robot.settings import robot_configs

    env = paper_env(robot_pos_noise_m=1.0)
    spec = env.agent_specs["robot_0"]
    _, cfg = robot_configs(spec, "social")
    assert (cfg.track_pos_noise_m, cfg.track_vel_noise_mps) == (1.0, spec.sensor.vel_noise_mps)
    robot = marl_social.policies(env)["robot_0"]
    np.testing.assert_allclose(np.diag(robot.belief.tracker._R),
                               [1.0, 1.0, spec.sensor.vel_noise_mps ** 2,
                                spec.sensor.vel_noise_mps ** 2])
