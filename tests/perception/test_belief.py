"""The robot's social perception (perception/belief.py; paper eq. 9-12, Algorithm 1): exact
discrete Bayes, negative information from its own depth rays, social information from a human
driver's braking, the traffic-speed product over humans (eq. 12) and robustness."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from marl_social.agents.cruise import CruiseVehiclePolicy
from marl_social.perception.belief import (
    BeliefConfig,
    PedestrianBelief,
    TrafficSpeedBelief,
    action_log_likelihood,
    bayes_step,
    crosswalk_hypotheses,
    markov_transition,
)

import marl_social
from marl_social.models.driver import DriverModel, driver_q_values
from marl_social.sim.observation import EGO_DIM, SLOT_DIM, SLOT_FIELDS, ObservationLayout
from marl_social.sim.road_map import RoadMap, Route

SEEDS = tuple(range(10))
CROSSWALK_X_M = 60.0
_F = {name: i for i, name in enumerate(SLOT_FIELDS)}


# -- helpers ------------------------------------------------------------------------------------
def _paper_env(**overrides):
    return marl_social.parallel_env(scenario="occluded_crosswalk", **overrides)


@functools.cache
def _robot_episode(pedestrian: str, seed: int, overrides: tuple = (), max_steps: int = 90):
    """The robot's own observations of one episode with every agent on its built-in planner
    and the robot on the cruise baseline (it brakes only for what it sees). Seeded like
    episode.record_episode. Returns (obs (T, size), robot sees the pedestrian (T,) bool,
    robot x (T,) [m], human speed (T,) [m/s], env) — the last three are the test's ground
    truth, the belief only gets obs."""
    env = _paper_env(pedestrian=pedestrian, **dict(overrides))
    pols = marl_social.policies(env)
    pols["robot_0"] = CruiseVehiclePolicy(env.agent_specs["robot_0"], env.obs_layout,
                                          env.road_map)
    for name, policy in pols.items():
        policy.reset(seed + env.possible_agents.index(name))
    obs, infos = env.reset(seed=seed)
    rows = []
    while "robot_0" in env.agents and len(rows) < max_steps:
        state = env.world.state
        rows.append((obs["robot_0"].copy(), "pedestrian_0" in infos["robot_0"]["visible"],
                     float(state[0, 0]), float(state[1, 3])))
        if state[0, 0] > CROSSWALK_X_M + 10.0:
            break
        obs, _, _, _, infos = env.step({a: pols[a](obs[a]) for a in env.agents})
    o, seen, rx, hv = zip(*rows)
    return np.array(o), np.array(seen), np.array(rx), np.array(hv), env


def _beliefs(episode, **kwargs):
    """Run a fresh PedestrianBelief over an episode's robot observations: (T, L) beliefs,
    (T,) p_pedestrian, the belief object."""
    obs, _, _, _, env = episode
    belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0", env.possible_agents,
                              **kwargs)
    probs, p_ped = [], []
    for o in obs:
        probs.append(belief.update(o))
        p_ped.append(belief.p_pedestrian)
    return np.array(probs), np.array(p_ped), belief


def _index(belief, name):
    return [h.name for h in belief.hypotheses].index(name)


# -- discrete Bayes -----------------------------------------------------------------------------
def test_markov_transition_moves_the_hazard_mass_evenly():
    t = markov_transition(3, 0.1)
    np.testing.assert_allclose(t, [[0.9, 0.05, 0.05], [0.05, 0.9, 0.05], [0.05, 0.05, 0.9]])
    np.testing.assert_allclose(t.sum(axis=0), 1.0)
    np.testing.assert_allclose(markov_transition(1, 0.5), [[1.0]])


def test_bayes_step_is_exact_on_a_hand_computed_case():
    """predicted = T prior = [0.475, 0.305, 0.22]; times likelihood [0.9, 0.1, 0.5] gives
    [0.4275, 0.0305, 0.11], sum 0.568."""
    post = bayes_step([0.5, 0.3, 0.2], np.log([0.9, 0.1, 0.5]), markov_transition(3, 0.1),
                      floor=1e-12)
    np.testing.assert_allclose(post, np.array([0.4275, 0.0305, 0.11]) / 0.568, rtol=1e-9)


def test_bayes_step_predicts_with_the_transition_matrix():
    """Column-stochastic T: predicted = T @ prior. With T moving all mass of hypothesis 0 to
    hypothesis 1 and a flat likelihood: [0.5, 0.3, 0.2] -> [0, 0.8, 0.2]."""
    t = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    post = bayes_step([0.5, 0.3, 0.2], np.zeros(3), t, floor=1e-12)
    np.testing.assert_allclose(post, [0.0, 0.8, 0.2], atol=1e-11)


def test_bayes_step_multiplies_independent_sources():
    """Two sources [0.9, 0.1, 0.5] and [0.5, 0.5, 1.0] on a prior [0.5, 0.3, 0.2], no
    transition: [0.225, 0.015, 0.1] / 0.34 (eq. 12: a product of likelihoods)."""
    ll = np.log([[0.9, 0.1, 0.5], [0.5, 0.5, 1.0]])
    post = bayes_step([0.5, 0.3, 0.2], ll, None, floor=1e-12)
    np.testing.assert_allclose(post, np.array([0.225, 0.015, 0.1]) / 0.34, rtol=1e-9)


def test_bayes_step_floor_and_garbage_sources():
    """A zero likelihood is floored (never all-zero); a source that is NaN, +inf or zero
    everywhere carries no information; the result is always a finite distribution."""
    floor = 1e-6
    with np.errstate(divide="ignore"):
        ll = np.log([1.0, 0.0, 0.0])
    post = bayes_step([0.5, 0.5, 0.0], ll, None, floor=floor)
    np.testing.assert_allclose(post, np.array([1.0, floor, floor]) / (1.0 + 2 * floor))
    prior = np.array([0.2, 0.3, 0.5])
    for garbage in ([np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0], [-np.inf] * 3):
        post = bayes_step(prior, np.array(garbage), None, floor=1e-12)
        np.testing.assert_allclose(post, prior, rtol=1e-9)
    post = bayes_step([np.nan, 0.0, 0.0], np.zeros(3), None)
    assert np.all(np.isfinite(post)) and post.min() > 0 and abs(post.sum() - 1) < 1e-12


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


# -- hypotheses and the human model ---------------------------------------------------------------
def test_crosswalk_hypotheses_of_the_paper_map():
    env = _paper_env()
    hyps = crosswalk_hypotheses(env.road_map, walk_speed_mps=1.3, curb_offset_m=1.0)
    assert [h.name for h in hyps] == ["none", "crossing_right", "crossing_left"]
    assert not hyps[0].present and hyps[1].present and hyps[2].present
    right, left = hyps[1], hyps[2]
    np.testing.assert_allclose(right.start_xy, [CROSSWALK_X_M, -4.5])  # curb y = -3.5
    np.testing.assert_allclose(right.walk_dir, [0.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(left.start_xy, [CROSSWALK_X_M, 4.5])
    xy = right.predict_xy(np.array([0.0, 1.0, 100.0]))
    np.testing.assert_allclose(xy, [[60.0, -4.5], [60.0, -3.2], [60.0, 4.5]], atol=1e-12)
    region = right.region()
    assert region.shape[1] == 2 and len(region) >= 9
    assert region[:, 1].min() >= -5.0 - 1e-9 and region[:, 1].max() <= -2.5 + 1e-9
    assert np.abs(region[:, 0] - CROSSWALK_X_M).max() <= 2.0
    with pytest.raises(ValueError):
        hyps[0].predict_xy(np.array([0.0]))


def test_one_rollout_gives_driver_q_values_for_every_hypothesis_and_traffic_speed():
    """human_q_values (one candidate evaluation) equals driver_q_values(DriverModel(v_desired
    = v)) for every (hypothesis, v_traffic) pair."""
    env = _paper_env()
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


# -- own sensors: negative and positive information ---------------------------------------------
def test_visible_empty_region_collapses_while_occluded_one_keeps_its_mass():
    """Own sensors only. With the human 60 m ahead and a 200 m sensor the robot sees the right
    curb: "crossing_right" drops below 0.05 within 5 steps. In the paper's scene the right curb
    is out of range, then hidden behind the human car, and keeps its prior mass, while the
    left curb (in view from about x = 20 m) collapses."""
    seen = _robot_episode("none", 0, (("human_lead_m", 60.0), ("robot_sensor_range_m", 200.0)),
                          max_steps=8)
    probs, _, belief = _beliefs(seen, use_social=False)
    right = _index(belief, "crossing_right")
    assert probs[4, right] < 0.05
    assert belief.last_likelihoods["visible_fraction"][right] > 0.9

    hidden = _robot_episode("none", 0)
    probs, _, belief = _beliefs(hidden, use_social=False)
    left = _index(belief, "crossing_left")
    robot_x = hidden[2]
    assert probs[4, right] > 0.24  # prior 0.25, nothing seen
    k = int(np.argmax(robot_x > 30.0))  # 30 m before the crosswalk: right curb in range
    assert probs[k, left] < 0.05
    assert probs[k, right] > 0.25
    fresh = PedestrianBelief(hidden[4].road_map, hidden[4].obs_layout, "robot_0",
                             hidden[4].possible_agents)
    vis = fresh.visible_fraction(hidden[4].obs_layout.decode(hidden[0][k]))
    assert vis[right] == 0.0 and vis[left] == 1.0


def test_seeing_the_pedestrian_is_positive_information():
    """Without social information, once the robot sees the crossing pedestrian the belief in
    "crossing_right" exceeds 0.9 within 3 steps and it is "perceived"."""
    episode = _robot_episode("crossing", 0)
    first_seen = int(np.argmax(episode[1]))
    probs, p_ped, belief = _beliefs(episode, use_social=False)
    right = _index(belief, "crossing_right")
    assert probs[first_seen + 3, right] > 0.9
    assert p_ped[first_seen + 3] == 1.0


# -- social information (eq. 9-10) ----------------------------------------------------------------
@pytest.fixture(scope="module")
def crossing_results():
    out = []
    for seed in SEEDS:
        episode = _robot_episode("crossing", seed)
        social, _, belief = _beliefs(episode)
        alone, _, _ = _beliefs(episode, use_social=False)
        out.append((episode, social, alone, _index(belief, "crossing_right")))
    return out


def test_social_belief_rises_because_the_human_brakes(crossing_results):
    """Paper Fig. 5: the robot cannot see the pedestrian (the human car hides it), but the
    human brakes. For every seed the belief in "crossing_right" is below 0.1 just before the
    human starts braking and above 0.9 the step before the robot first sees the pedestrian."""
    ok = 0
    for (_, seen, _, human_v, _), social, _, right in crossing_results:
        first_seen = int(np.argmax(seen))
        brake = int(np.argmax(human_v < human_v[0] - 0.05))  # first step the human is slower
        assert 5 < brake < first_seen
        before = social[brake - 1, right] < 0.1
        ok += before and social[first_seen - 1, right] > 0.9
    assert ok == len(SEEDS), f"{ok}/{len(SEEDS)} seeds"


def test_without_social_information_the_belief_stays_low_until_seen(crossing_results):
    for (_, seen, _, _, _), _, alone, right in crossing_results:
        first_seen = int(np.argmax(seen))
        assert alone[:first_seen, right].max() < 0.5


@pytest.mark.parametrize("pedestrian", ["none", "waiting"])
def test_social_belief_stays_low_when_the_human_keeps_its_speed(pedestrian):
    """Paper Fig. 6: no crossing pedestrian, the human drives on; from 50 m before the
    crosswalk until the robot has passed it, P(crossing pedestrian) < 0.1 for every seed."""
    for seed in SEEDS:
        episode = _robot_episode(pedestrian, seed)
        _, p_ped, _ = _beliefs(episode)
        robot_x = episode[2]
        window = (robot_x >= CROSSWALK_X_M - 50.0) & (robot_x <= CROSSWALK_X_M + 5.0)
        assert window.sum() > 40
        assert p_ped[window].max() < 0.1, (seed, p_ped[window].max())


# -- social information I: the traffic speed, product over humans (eq. 12) ----------------------
def _synthetic_world(n_humans: int):
    """A straight road without crosswalks, the robot behind n_humans humans, all driving
    13 m/s; noise-free observation vectors built by hand."""
    names = ["robot_0"] + [f"human_{i}" for i in range(n_humans)]
    routes = {name: Route([[-50.0, y], [1000.0, y]], name)
              for name, y in zip(names, (0.0, -3.5, 3.5))}
    road_map = RoadMap(lanes=(), crosswalks=(), static_polygons=(), routes=routes)
    layout = ObservationLayout(n_slots=4, n_rays=8)

    def observe(t_s, visible):
        obs = np.zeros(layout.size, dtype=np.float32)
        obs[:8] = [13.0 * t_s, 0.0, 1.0, 0.0, 13.0, 50.0, math.radians(60.0), 0.0]
        for k, i in enumerate(visible):
            slot = np.zeros(SLOT_DIM)
            slot[[_F["present"], _F["id"], _F["x"], _F["y"], _F["vx"], _F["cos_psi"],
                  _F["length"], _F["width"]]] = [1, i + 2, 20.0 + 10.0 * i + 13.0 * t_s,
                                                 (-3.5, 3.5)[i], 13.0, 1.0, 4.5, 1.8]
            obs[EGO_DIM + k * SLOT_DIM:EGO_DIM + (k + 1) * SLOT_DIM] = slot
        obs[EGO_DIM + layout.n_slots * SLOT_DIM:] = 50.0
        return obs

    return road_map, layout, names, observe


def test_traffic_speed_belief_multiplies_over_humans():
    """Two humans holding 13 m/s concentrate the v_traffic belief on 13 more than one does."""
    road_map, layout, names, observe = _synthetic_world(2)
    p13 = {}
    for visible in ((0,), (0, 1)):
        belief = PedestrianBelief(road_map, layout, "robot_0", names)
        assert [h.name for h in belief.hypotheses] == ["none"]
        for step in range(12):
            belief.update(observe(0.1 * step, visible))
        grid = list(belief.traffic.grid_mps)
        p13[len(visible)] = belief.traffic.probabilities[grid.index(13.0)]
        assert abs(belief.traffic.expected_mps - 13.0) < 1.0
    assert 0.25 < p13[1] < p13[2]
    assert 1.0 - p13[2] < 0.5 * (1.0 - p13[1])


def test_traffic_speed_belief_update_is_a_product():
    ll = np.log([0.2, 0.3, 0.5])
    one = TrafficSpeedBelief([8.0, 11.5, 13.0], hazard_per_step=0.0)
    one.update(ll[None])
    two = TrafficSpeedBelief([8.0, 11.5, 13.0], hazard_per_step=0.0)
    two.update(np.stack([ll, ll]))
    np.testing.assert_allclose(one.probabilities, [0.2, 0.3, 0.5], rtol=1e-9)
    np.testing.assert_allclose(two.probabilities, np.array([0.04, 0.09, 0.25]) / 0.38,
                               rtol=1e-9)
    assert two.expected_mps > one.expected_mps


# -- the epsilon threshold and robustness -------------------------------------------------------
def test_live_excludes_hypotheses_below_epsilon():
    env = _paper_env()
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
    road_map, layout, names, observe = _synthetic_world(1)
    env = _paper_env()
    crosswalk_map = RoadMap(lanes=env.road_map.lanes, crosswalks=env.road_map.crosswalks,
                            static_polygons=(), routes=road_map.routes)
    for rm in (road_map, crosswalk_map):
        belief = PedestrianBelief(rm, layout, "robot_0", names)
        for step in range(20):
            obs = observe(0.1 * step, (0,))
            obs[EGO_DIM + _F["vx"]] = 1000.0 * (-1) ** step
            if step % 3 == 0:
                obs[EGO_DIM + layout.n_slots * SLOT_DIM:] = np.nan
            if step % 5 == 0:
                obs[4] = 1e4
            p = belief.update(obs)
            assert np.all(np.isfinite(p)) and p.min() > 0 and abs(p.sum() - 1.0) < 1e-9
            assert np.all(np.isfinite(belief.traffic.probabilities))
            assert 0.0 <= belief.p_pedestrian <= 1.0


# -- social+beta: the human's rationality inferred jointly --------------------------------------
def test_rationality_belief_separates_an_erratic_human_from_a_rational_one():
    """social+beta (BeliefConfig.beta_grid_hat): the robot's belief over the human's beta ends
    at the grid's low end for a nearly random human (beta 0.003) and well above it for a
    rational one (beta 10), and the erratic human's random braking raises the pedestrian
    belief less on average than under a fixed beta_hat."""
    from marl_social.agents.robot.planner import BETA_GRID_HAT

    log_grid = np.log(BETA_GRID_HAT)
    false_alarm = {"fixed": [], "inferred": []}
    for human_beta in (0.003, 10.0):
        for seed in range(6):
            obs, _, robot_x, _, env = _robot_episode("none", seed, (("human_beta", human_beta),))
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
