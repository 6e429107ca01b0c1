"""The robot's own sensors (perception/belief/own_sensors.py): negative information from its
depth rays and positive information from a seen crossing pedestrian."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.envs.policies import policies
from marl_social.perception.belief import PedestrianBelief
from tests.perception.belief.episodes import hyp_index, robot_episode, run_beliefs


def test_visible_empty_region_collapses_while_occluded_one_keeps_its_mass():
    """Own sensors only. With the human 60 m ahead and a 200 m sensor the robot sees the right
    curb: "crossing_right" (all its bins) drops below 0.05 within 5 steps. In the paper's
    scene the right curb is out of range, then hidden behind the human car, and its entry bins
    keep their prior mass, while the left crossing (in view from about x = 20 m) collapses."""
    seen = robot_episode("none", 0, (("human_lead_m", 60.0), ("robot_sensor_range_m", 200.0)),
                          max_steps=8)
    probs, _, belief = run_beliefs(seen, use_social=False)
    right = hyp_index(belief, "crossing_right")
    right_entry = hyp_index(belief, "crossing_right", progress_bin=0)
    assert probs[4] @ right < 0.05
    assert belief.last_likelihoods["visible_fraction"][right_entry].min() > 0.9

    hidden = robot_episode("none", 0)
    probs, _, belief = run_beliefs(hidden, use_social=False)
    left = hyp_index(belief, "crossing_left")
    prior_entry = belief.prior @ right_entry
    robot_x = hidden[2]
    assert probs[4] @ right > 0.95 * (belief.prior @ right)  # nothing seen
    k = int(np.argmax(robot_x > 30.0))  # 30 m before the crosswalk: right curb in range
    assert probs[k] @ left < 0.05 * (belief.prior @ left)
    assert probs[k] @ right_entry > prior_entry
    fresh = PedestrianBelief(hidden[4].road_map, hidden[4].obs_layout, "robot_0",
                             hidden[4].possible_agents)
    vis = fresh.visible_fraction(hidden[4].obs_layout.decode(hidden[0][k]))
    left_entry = hyp_index(belief, "crossing_left", progress_bin=0)
    assert vis[right_entry].max() == 0.0 and vis[left_entry].min() == 1.0


def test_seeing_the_pedestrian_is_positive_information():
    """Without social information, once the robot sees the crossing pedestrian the belief in
    "crossing_right" exceeds 0.9 within 3 steps and it is "perceived"."""
    episode = robot_episode("crossing", 0)
    first_seen = int(np.argmax(episode[1]))
    probs, p_ped, belief = run_beliefs(episode, use_social=False)
    right = hyp_index(belief, "crossing_right")
    assert probs[first_seen + 3] @ right > 0.9
    assert p_ped[first_seen + 3] == 1.0


def test_detection_and_negative_information_work_per_hypothesis():
    """A pedestrian the robot sees in the middle of the road matches the hypotheses of that
    progress bin on its crossing, not the curb entry; a visible empty road rules out the
    on-road bins while the hidden curb entry keeps its mass."""
    from marl_social.perception.belief import OwnSensors

    episode = robot_episode("none", 0)
    env = episode[4]
    belief = PedestrianBelief(env.road_map, env.obs_layout, "robot_0", env.possible_agents)
    sensors = OwnSensors(belief.hypotheses, belief.config)
    hyps = belief.hypotheses
    mid = sensors.match_pedestrians(np.array([[60.0, 0.6]]), np.array([[0.0, 1.2]]))
    matched = {(hyps[i].path, hyps[i].progress_bin) for i in np.flatnonzero(mid)}
    assert matched == {("crossing_right", 2), ("crossing_right", 1)}
    assert not sensors.match_pedestrians(np.array([[60.0, -4.5]]), np.zeros((1, 2))).any()
    k = int(np.argmax(episode[2] > 30.0))
    vis = sensors.visible_fraction(env.obs_layout.decode(episode[0][k]))
    far_bins = hyp_index(belief, "crossing_right", progress_bin=2)
    assert vis[far_bins].min() > 0.5 and vis[hyp_index(belief, "crossing_right", 0)].max() == 0


@pytest.mark.parametrize("scenario", ["occluded_crosswalk", "t_intersection"])
def test_matching_per_path_equals_each_hypothesis_matches(scenario):
    """OwnSensors matches the hypotheses of one path at once: the same answer as
    Hypothesis.matches of each, for seen agents in and around every hypothesis' region."""
    env = marl_social.parallel_env(scenario=scenario)
    belief = policies(env)["robot_0"].belief
    sensors, v_min = belief.own_sensors, belief.config.walking_speed_min_mps
    present = [h for h in belief.hypotheses if h.present]
    rng = np.random.default_rng(7)
    n_matched = 0
    for _ in range(300):
        n = int(rng.integers(1, 4))
        anchors = np.array([present[i].region()[rng.integers(15)]
                            for i in rng.integers(len(present), size=n)])
        xy = anchors + rng.normal(size=(n, 2)) * 2.0
        for kind, scale in (("pedestrian", 1.5), ("vehicle", 8.0)):
            vel = rng.normal(size=(n, 2)) * scale
            expected = np.array([h.present and h.kind == kind and h.matches(xy, vel, v_min)
                                 for h in belief.hypotheses])
            assert np.array_equal(sensors._match(kind, xy, vel), expected)
            n_matched += int(expected.sum())
    assert n_matched > 50  # the draws do exercise matches
