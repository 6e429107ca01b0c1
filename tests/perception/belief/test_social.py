"""Social information (perception/belief/social.py; paper eq. 9-11): the action likelihood,
the robot's model of a human, a human driver's braking as evidence, and its rationality."""

from __future__ import annotations

import math

import numpy as np
import pytest

from marl_social.models.driver import DriverModel, driver_q_values
from marl_social.perception.belief import (
    BeliefConfig,
    PedestrianBelief,
    action_log_likelihood,
    bayes_step,
    markov_transition,
)
from tests.perception.belief.episodes import (
    CROSSWALK_X_M,
    SEEDS,
    hyp_index,
    paper_env,
    robot_episode,
    run_beliefs,
)


def test_action_likelihood_is_eq10():
    """P(a | x) = sum_u softmax(-beta Q(x, .))[u] N(a; u, sigma^2), by hand for 2 hypotheses
    and 3 actions."""
    q = np.array([[0.0, 1.0, 3.0], [2.0, 0.0, 0.5]])
    actions = np.array([-2.0, 0.0, 1.0])
    beta, sigma, a = 0.7, 0.8, -0.4
    p = np.exp(-beta * q) / np.exp(-beta * q).sum(axis=1, keepdims=True)
    gauss = np.exp(-0.5 * ((a - actions) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))
    expected = p @ gauss
    got = np.exp(action_log_likelihood(q, beta, a, actions, sigma))
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    # beta = inf: only the argmin counts
    got = np.exp(action_log_likelihood(q, math.inf, a, actions, sigma))
    np.testing.assert_allclose(got, [gauss[0], gauss[1]], rtol=1e-12)


def test_action_likelihood_with_absurd_inputs_stays_usable():
    q = np.array([[0.0, 1.0, 3.0], [2.0, 0.0, 0.5]])
    actions = np.array([-2.0, 0.0, 1.0])
    for a in (1e6, -1e6, 1e200, math.nan, math.inf):
        ll = action_log_likelihood(q, 5.0, a, actions, 1.0)
        post = bayes_step([0.5, 0.5], ll, markov_transition(2, 0.01))
        assert np.all(np.isfinite(post)) and post.min() > 0, a
    # far beyond the largest action, the hypothesis that most prefers it wins
    ll = action_log_likelihood(q, 1.0, 50.0, actions, 1.0)
    assert ll[1] > ll[0]


def test_one_rollout_gives_driver_q_values_for_every_hypothesis_and_traffic_speed():
    """human_q_values (one candidate evaluation) equals driver_q_values(DriverModel(v_desired
    = v)) for every (hypothesis, v_traffic) pair."""
    env = paper_env()
    belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0", env.possible_agents)
    route = env.road_map.routes["human_0"]
    q = belief.human_q_values(route, 70.0, 9.0, -2.0)  # (L, V, A), 16 m before the crosswalk
    scene = belief.hypothesis_scene()
    for k, v in enumerate(belief.traffic.grid_mps):
        model = DriverModel(theta=belief.config.theta_hat, beta=belief.config.beta_hat,
                            v_desired_mps=float(v))
        ref = driver_q_values(model, route, 70.0, 9.0, -2.0, scene, env.road_map.crosswalks)
        np.testing.assert_allclose(q[:, k], ref, rtol=1e-12, atol=1e-9)
    # the hypotheses matter: with a pedestrian starting to cross, holding speed is expensive
    hold = belief.model.first_actions_mps2.index(0.0)
    assert q[1, 2, hold] > q[0, 2, hold] + 100.0


@pytest.fixture(scope="module")
def crossing_results():
    out = []
    for seed in SEEDS:
        episode = robot_episode("crossing", seed)
        social, _, belief = run_beliefs(episode)
        alone, _, _ = run_beliefs(episode, use_social=False)
        out.append((episode, social, alone, hyp_index(belief, "crossing_right")))
    return out


@pytest.mark.slow
def test_social_belief_rises_because_the_human_brakes(crossing_results):
    """Paper Fig. 5: the robot cannot see the pedestrian (the human car hides it), but the
    human brakes. For every seed the belief in "crossing_right" is below 0.1 just before the
    human starts braking and above 0.9 the step before the robot first sees the pedestrian."""
    ok = 0
    for (_, seen, _, human_v, _), social, _, right in crossing_results:
        first_seen = int(np.argmax(seen))
        brake = int(np.argmax(human_v < human_v[0] - 0.05))  # first step the human is slower
        assert 5 < brake < first_seen
        before = social[brake - 1] @ right < 0.1
        ok += before and social[first_seen - 1] @ right > 0.9
    assert ok == len(SEEDS), f"{ok}/{len(SEEDS)} seeds"


@pytest.mark.slow
def test_without_social_information_the_belief_stays_low_until_seen(crossing_results):
    for (_, seen, _, _, _), _, alone, right in crossing_results:
        first_seen = int(np.argmax(seen))
        assert (alone[:first_seen] @ right).max() < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("pedestrian", ["none", "waiting"])
def test_social_belief_stays_low_when_the_human_keeps_its_speed(pedestrian):
    """Paper Fig. 6: no crossing pedestrian, the human drives on; from 50 m before the
    crosswalk until the robot has passed it, P(crossing pedestrian) < 0.1 for every seed."""
    for seed in SEEDS:
        episode = robot_episode(pedestrian, seed)
        _, p_ped, _ = run_beliefs(episode)
        robot_x = episode[2]
        window = (robot_x >= CROSSWALK_X_M - 50.0) & (robot_x <= CROSSWALK_X_M + 5.0)
        assert window.sum() > 40
        assert p_ped[window].max() < 0.1, (seed, p_ped[window].max())


@pytest.mark.slow
def test_rationality_belief_separates_an_erratic_human_from_a_rational_one():
    """social+beta (BeliefConfig.beta_grid_hat): the robot's belief over the human's beta ends
    at the grid's low end for a nearly random human (beta 0.003) and well above it for a
    rational one (beta 10), and the erratic human's random braking raises the pedestrian
    belief less on average than under a fixed beta_hat."""
    from marl_social.agents.robot.settings import BETA_GRID_HAT

    log_grid = np.log(BETA_GRID_HAT)
    false_alarm = {"fixed": [], "inferred": []}
    for human_beta in (0.003, 10.0):
        for seed in range(6):
            obs, _, robot_x, _, env = robot_episode("none", seed, (("human_beta", human_beta),))
            window = (robot_x >= CROSSWALK_X_M - 50.0) & (robot_x <= CROSSWALK_X_M + 5.0)
            for name, cfg in (("fixed", BeliefConfig()),
                              ("inferred", BeliefConfig(beta_grid_hat=BETA_GRID_HAT))):
                belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0",
                                          env.possible_agents, cfg)
                p_ped, beta_mean = [], None
                for o in obs:
                    belief.update(o)
                    p_ped.append(belief.p_pedestrian)
                    b = belief.beta_beliefs().get("human_0")
                    beta_mean = math.exp(b @ log_grid) if b is not None else beta_mean
                if name == "fixed":
                    assert belief.beta_beliefs() == {}
                else:
                    if human_beta < 1:
                        assert beta_mean < 0.05, (seed, beta_mean)
                    else:
                        assert beta_mean > 0.2, (seed, beta_mean)
                if human_beta < 1:
                    false_alarm[name].append(max(np.array(p_ped)[window]))
    assert np.mean(false_alarm["inferred"]) < np.mean(false_alarm["fixed"])


def test_one_extreme_observation_moves_the_log_odds_by_at_most_the_bound():
    """BeliefConfig.max_log_likelihood_ratio bounds what one observed action does: each human's
    log-likelihoods span at most the bound, and the human's observation, however absurd its
    velocity (a_obs up to +-50 m/s^2 off), moves the posterior log-odds of a crossing
    pedestrian by at most the bound compared with the same step without it."""
    import copy

    from marl_social.perception.belief.action_model import bounded_log_likelihood
    from marl_social.sim.observation import EGO_DIM, SLOT_DIM, SLOT_INDEX

    bound = BeliefConfig().max_log_likelihood_ratio
    ll = bounded_log_likelihood(np.array([0.0, -1.0, -50.0, -1e300]), bound)
    assert ll.max() - ll.min() <= bound + 1e-12
    episode = robot_episode("crossing", 1)
    obs, seen = episode[0], episode[1]
    _, _, belief = run_beliefs((obs[:5],) + episode[1:])
    first_seen = int(np.argmax(seen))

    def log_odds(b, o):
        b = copy.deepcopy(b)
        b.update(o)
        return math.log(b.p_pedestrian / (1.0 - b.p_pedestrian))

    checked = 0
    for k in range(5, first_seen):
        rows = obs[k][EGO_DIM:EGO_DIM + episode[4].obs_layout.n_slots * SLOT_DIM]
        ids = rows.reshape(-1, SLOT_DIM)[:, SLOT_INDEX["id"]]
        slot = EGO_DIM + int(np.flatnonzero(np.round(ids) == 2)[0]) * SLOT_DIM  # human_0
        without = obs[k].copy()
        without[slot:slot + SLOT_DIM] = 0.0
        reference = log_odds(belief, without)
        for dv in (-5.0, -0.8, 0.0, 0.8, 5.0):
            o = obs[k].copy()
            o[slot + SLOT_INDEX["vx"]] += dv
            assert abs(log_odds(belief, o) - reference) <= bound + 1e-9, (k, dv)
            checked += 1
        belief.update(obs[k])
    assert checked > 40


def test_the_robot_trusts_a_noisier_track_less():
    """The sigma of P(a_obs | x) includes the robot's own track error: larger for a sensor
    that measures velocity with 0.5 m/s noise than with the default 0.1 m/s."""
    episode = robot_episode("none", 0, max_steps=20)
    sigmas = {}
    for noise in (0.1, 0.5):
        _, _, belief = run_beliefs(episode, config=BeliefConfig(track_vel_noise_mps=noise))
        sigmas[noise] = belief.social.scoring.observation_sigma_mps2(belief.tracker.tracks(), 0, 0.0)
    assert BeliefConfig().accel_noise_mps2 < sigmas[0.1] < sigmas[0.5]


def test_the_robot_model_of_the_humans_is_its_own():
    """Defaults that are not the simulated humans' truth: theta_hat differs from the humans'
    CostWeights, the traffic-speed grid (fractions of the limit) does not contain their
    11.5 m/s, the assumed view differs from the scenario's human sensor (60 m, 60 deg)."""
    from marl_social.sim.costs import CostWeights

    cfg = BeliefConfig()
    env = paper_env()
    human = env.agent_specs["human_0"]
    assert cfg.theta_hat != human.cost_weights and cfg.theta_hat != CostWeights()
    grid = cfg.traffic_grid_mps(env.road_map.speed_limit_mps)
    assert not np.any(np.isclose(grid, human.v_desired_mps))
    assert grid.max() <= env.road_map.speed_limit_mps + 1e-9
    assert (cfg.human_range_m, cfg.human_half_fov_rad) != (human.sensor.range_m,
                                                           human.sensor.half_angle_rad)
